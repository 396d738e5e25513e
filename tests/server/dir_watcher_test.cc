// Watching the maps folder (server/dir_watcher.h) with real inotify on a real folder: which
// file names stand for maps, and the events of files written, renamed into place, deleted.
#include "server/dir_watcher.h"

#include <gtest/gtest.h>
#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

// Only <stem>.scnl names a map: SaveMap's temporaries and hidden files do not.
TEST(DirWatcherTest, MapNameOfFile) {
  EXPECT_EQ(MapNameOfFile("site.scnl"), "site");
  EXPECT_EQ(MapNameOfFile("site.v2.scnl"), "site.v2");
  EXPECT_EQ(MapNameOfFile("site.scnl.tmp.1234"), "");
  EXPECT_EQ(MapNameOfFile(".site.scnl"), "");
  EXPECT_EQ(MapNameOfFile(".scnl"), "");
  EXPECT_EQ(MapNameOfFile("notes.txt"), "");
}

// A folder that does not exist cannot be watched, and says which.
TEST(DirWatcherTest, MissingFolderIsAnError) {
  auto watcher = DirWatcher::Open("/nonexistent/maps");
  ASSERT_FALSE(watcher.ok());
  EXPECT_NE(watcher.status().message().find("/nonexistent/maps"), std::string::npos);
}

class DirWatcherEventsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) /
           ("dir_watcher_test_" + std::to_string(::getpid()) + "_" + test->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    auto watcher = DirWatcher::Open(dir_.string());
    ASSERT_TRUE(watcher.ok()) << watcher.status().ToString();
    watcher_ = std::move(watcher).value();
  }
  void TearDown() override {
    watcher_.reset();
    fs::remove_all(dir_);
  }

  // Waits (up to 10 s) until the watcher has events, then takes them all.
  std::vector<MapFileEvent> Events(bool* lost = nullptr) {
    pollfd item{watcher_->fd(), POLLIN, 0};
    EXPECT_EQ(::poll(&item, 1, 10000), 1) << "no event came";
    bool overflowed = false, gone = false;
    std::vector<MapFileEvent> events = watcher_->ReadEvents(&overflowed, &gone);
    EXPECT_FALSE(overflowed);
    if (lost != nullptr) *lost = gone;
    return events;
  }
  void Write(const std::string& name) const { std::ofstream(dir_ / name) << "bytes"; }

  fs::path dir_;
  std::unique_ptr<DirWatcher> watcher_;
};

// A map file written in place is one event naming its map; other files are not reported.
TEST_F(DirWatcherEventsTest, WrittenMapFileIsReported) {
  Write("notes.txt");
  Write("site.scnl");
  const std::vector<MapFileEvent> events = Events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].map, "site");
  EXPECT_FALSE(events[0].removed);
}

// SaveMap's temporary file renamed into place is reported under the map's name only
// when it arrives; deleting the map is a removal.
TEST_F(DirWatcherEventsTest, RenameIntoPlaceAndDelete) {
  Write("site.scnl.tmp.77");
  fs::rename(dir_ / "site.scnl.tmp.77", dir_ / "site.scnl");
  std::vector<MapFileEvent> events = Events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].map, "site");
  EXPECT_FALSE(events[0].removed);
  fs::remove(dir_ / "site.scnl");
  events = Events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].map, "site");
  EXPECT_TRUE(events[0].removed);
}

// Deleting the watched folder itself is reported as lost: no more events will come.
TEST_F(DirWatcherEventsTest, DeletedFolderIsLost) {
  fs::remove_all(dir_);
  bool lost = false;
  Events(&lost);
  EXPECT_TRUE(lost);
}

}  // namespace
}  // namespace sceneloc
