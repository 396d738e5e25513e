// The frame keeper on its own (server/frame_keeper.h): which frames of a session it keeps,
// the quota, the memory bound, a restart, delete, and fetching in pages. Real files in a
// temporary folder; frames are distinct byte strings (the keeper never decodes them).
#include "server/frame_keeper.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "common/util/file_io.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;
using Time = FrameKeeper::SystemClock::time_point;

class FrameKeeperTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ =
        fs::path(::testing::TempDir()) /
        ("keeper_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    options_.dir = dir_.string();
    options_.min_unknown_frames = 3;
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::unique_ptr<FrameKeeper> Open() {
    auto keeper = FrameKeeper::Open(options_);
    EXPECT_TRUE(keeper.ok()) << keeper.status().ToString();
    return keeper.ok() ? std::move(keeper).value() : nullptr;
  }

  // Frame `i` of a session: an UNKNOWN answer unless `localised`.
  SessionFrame Frame(int i, bool localised = false, const std::string& session = "rover") {
    SessionFrame f;
    f.client = "robot";
    f.map = "campus";
    f.session = session;
    f.map_checksum = 0xabcdef;
    bytes_.push_back("JPEG-" + session + "-" + std::to_string(i) + std::string(1000, 'x'));
    f.jpeg = bytes_.back();
    f.frame_place = i;
    f.frame_confidence = localised ? 0.97 : 0.2;
    f.session_place = i;
    f.session_place_name = "Image" + std::to_string(i) + ".jpg";
    f.session_probability = localised ? 0.96 : 0.3;
    f.localised = localised;
    return f;
  }

  // Bytes of every file under the folder.
  int64_t OnDisk() const {
    int64_t bytes = 0;
    for (const auto& e : fs::recursive_directory_iterator(dir_)) {
      if (e.is_regular_file()) bytes += static_cast<int64_t>(e.file_size());
    }
    return bytes;
  }

  fs::path dir_;
  KeepFramesOptions options_;
  std::deque<std::string> bytes_;  // the frames' bytes, alive while the keeper reads them
  Time now_ = FrameKeeper::SystemClock::now();
};

// A streak shorter than min_unknown_frames keeps nothing; the third UNKNOWN frame in a row
// keeps the streak from its first frame, and every UNKNOWN frame after it, exactly as sent,
// until a LOCALISED answer ends the run; the next streak is a new run that knows where the
// session last was.
TEST_F(FrameKeeperTest, KeepsStreaksFromTheirFirstFrameAndRemembersTheLastPlace) {
  auto keeper = Open();
  ASSERT_NE(keeper, nullptr);
  keeper->Observe(Frame(0), now_);
  keeper->Observe(Frame(1), now_);
  keeper->Observe(Frame(2, true), now_);  // the streak ends at 2
  keeper->Observe(Frame(3), now_);
  keeper->Observe(Frame(4), now_);
  keeper->Flush();
  EXPECT_EQ(keeper->List("").value().size(), 0u);
  EXPECT_EQ(keeper->List("campus").status().code(), StatusCode::kNotFound);

  SessionFrame features = Frame(5);
  features.jpeg = {};  // a feature set: neither kept nor counted
  keeper->Observe(features, now_);
  keeper->Observe(Frame(6), now_);  // the third JPEG in a row
  keeper->Observe(Frame(7), now_);
  keeper->Observe(Frame(8, true), now_);
  keeper->Observe(Frame(9), now_);
  keeper->Observe(Frame(10), now_);
  keeper->Observe(Frame(11), now_);
  keeper->Flush();

  auto runs = keeper->List("campus");
  ASSERT_TRUE(runs.ok()) << runs.status().ToString();
  ASSERT_EQ(runs->size(), 2u);
  const KeptRun& first = (*runs)[0];
  EXPECT_EQ(first.frames, 4);  // 3, 4, 6, 7
  EXPECT_EQ(first.session, "rover");
  EXPECT_EQ(first.client, "robot");
  EXPECT_EQ(first.map_checksum, 0xabcdefu);
  EXPECT_EQ(first.anchor_place, 2);
  EXPECT_EQ(first.anchor_name, "Image2.jpg");
  const KeptRun& second = (*runs)[1];
  EXPECT_EQ(second.frames, 3);
  EXPECT_EQ(second.anchor_place, 8);
  EXPECT_NE(first.run, second.run);
  EXPECT_EQ(first.run.find("-rover"), 16u) << first.run;  // "<YYYYmmddTHHMMSSZ>-rover"

  auto page = keeper->Fetch("campus", first.run, 0, int64_t{1} << 30);
  ASSERT_TRUE(page.ok()) << page.status().ToString();
  ASSERT_EQ(page->frames.size(), 4u);
  EXPECT_EQ(page->next_frame, 4);
  const int kept[] = {3, 4, 6, 7};
  for (int i = 0; i < 4; ++i) {
    // bytes_[k] is frame k's (one Frame() call per frame, in order).
    EXPECT_EQ(page->frames[static_cast<size_t>(i)].jpeg, bytes_[static_cast<size_t>(kept[i])]) << i;
  }
  // The run's folder holds only images: a walk for sceneloc-train --extend.
  for (const auto& e : fs::directory_iterator(dir_ / "campus" / first.run)) {
    EXPECT_EQ(e.path().extension(), ".jpg") << e.path();
  }
  const KeepFramesCounts counts = keeper->Counts();
  EXPECT_EQ(counts.kept, 7u);
  EXPECT_EQ(counts.bytes_used, OnDisk());
  EXPECT_EQ(counts.pending_bytes, 0);
}

// Sessions are kept apart (by client, map and name), and a reset forgets where the session
// last was.
TEST_F(FrameKeeperTest, SessionsAreApartAndAResetForgetsThePlace) {
  auto keeper = Open();
  ASSERT_NE(keeper, nullptr);
  keeper->Observe(Frame(0, true, "a"), now_);
  for (int i = 1; i <= 2; ++i) {
    keeper->Observe(Frame(i, false, "a"), now_);
    keeper->Observe(Frame(i, false, "b"), now_);
  }
  SessionFrame reset = Frame(3, false, "a");
  reset.reset = true;
  keeper->Observe(reset, now_);  // "a" starts again: a streak of one
  keeper->Observe(Frame(3, false, "b"), now_);
  keeper->Observe(Frame(4, false, "a"), now_);
  keeper->Observe(Frame(5, false, "a"), now_);
  keeper->Flush();
  auto runs = keeper->List("campus");
  ASSERT_TRUE(runs.ok()) << runs.status().ToString();
  ASSERT_EQ(runs->size(), 2u);
  for (const KeptRun& run : *runs) {
    EXPECT_EQ(run.frames, 3) << run.session;
    EXPECT_EQ(run.anchor_place, -1) << run.session;  // "a" reset; "b" was never LOCALISED
  }
}

// Never beyond the quota: frames that would pass it are dropped and counted, what is on
// disk stays within it, and deleting a run frees its bytes for new frames.
TEST_F(FrameKeeperTest, NeverPassesTheQuotaAndDeleteFreesIt) {
  options_.quota_bytes = 5000;  // about three frames and their record
  auto keeper = Open();
  ASSERT_NE(keeper, nullptr);
  for (int i = 0; i < 10; ++i) keeper->Observe(Frame(i), now_);
  keeper->Flush();
  KeepFramesCounts counts = keeper->Counts();
  EXPECT_GT(counts.kept, 0u);
  EXPECT_GT(counts.dropped_quota, 0u);
  EXPECT_EQ(counts.kept + counts.dropped_quota, 10u);
  EXPECT_LE(OnDisk(), options_.quota_bytes);
  EXPECT_EQ(counts.bytes_used, OnDisk());

  auto runs = keeper->List("campus");
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs->size(), 1u);
  ASSERT_TRUE(keeper->Delete("campus", (*runs)[0].run).ok());
  EXPECT_EQ(keeper->Counts().bytes_used, 0);
  EXPECT_EQ(OnDisk(), 0);
  // The session was still in its streak: its next frame opens a new run, which now fits.
  keeper->Observe(Frame(10), now_);
  keeper->Flush();
  runs = keeper->List("campus");
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs->size(), 1u);
  EXPECT_EQ((*runs)[0].frames, 1);
  EXPECT_EQ(keeper->Delete("campus", "no-such-run").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(keeper->Delete("campus", "../campus").status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(keeper->Fetch("../etc", "x", 0, 1).status().code(), StatusCode::kInvalidArgument);
}

// Frames wait in memory within max_pending_bytes; beyond it they are dropped and counted.
TEST_F(FrameKeeperTest, FramesWaitingInMemoryAreBounded) {
  options_.min_unknown_frames = 10;
  options_.max_pending_bytes = 4000;  // three frames of about 1 KB
  auto keeper = Open();
  ASSERT_NE(keeper, nullptr);
  for (int i = 0; i < 6; ++i) keeper->Observe(Frame(i), now_);
  const KeepFramesCounts counts = keeper->Counts();
  EXPECT_EQ(counts.dropped_memory, 3u);
  EXPECT_LE(counts.pending_bytes, options_.max_pending_bytes);
  for (int i = 6; i < 10; ++i) keeper->Observe(Frame(i), now_);
  keeper->Flush();
  EXPECT_EQ(keeper->Counts().pending_bytes, 0);
}

// The folder survives a restart: its usage is counted from the files, a write cut short is
// cleaned away, the runs are listed, and new runs do not reuse their names.
TEST_F(FrameKeeperTest, TheFolderSurvivesARestart) {
  std::string first_run;
  {
    auto keeper = Open();
    ASSERT_NE(keeper, nullptr);
    for (int i = 0; i < 4; ++i) keeper->Observe(Frame(i), now_);
  }  // the destructor writes what was queued
  {
    std::ofstream cut(dir_ / "campus" / "leftover.jpg.tmp.123");
    cut << "half a frame";
  }
  const int64_t before = OnDisk() - 12;
  auto keeper = Open();
  ASSERT_NE(keeper, nullptr);
  EXPECT_FALSE(fs::exists(dir_ / "campus" / "leftover.jpg.tmp.123"));
  EXPECT_EQ(keeper->Counts().bytes_used, before);
  auto runs = keeper->List("");
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs->size(), 1u);
  EXPECT_EQ((*runs)[0].frames, 4);
  for (int i = 0; i < 3; ++i) keeper->Observe(Frame(10 + i), now_);  // the same second
  keeper->Flush();
  runs = keeper->List("campus");
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs->size(), 2u);
  EXPECT_NE((*runs)[0].run, (*runs)[1].run);
  EXPECT_EQ(keeper->Counts().bytes_used, OnDisk());
}

// Fetching pages through a run: each page holds what fits in the bytes asked for (at least
// one frame), and next_frame leads to the next.
TEST_F(FrameKeeperTest, FetchesARunInPages) {
  auto keeper = Open();
  ASSERT_NE(keeper, nullptr);
  for (int i = 0; i < 7; ++i) keeper->Observe(Frame(i), now_);
  keeper->Flush();
  auto runs = keeper->List("campus");
  ASSERT_TRUE(runs.ok());
  const std::string run = (*runs)[0].run;
  std::vector<std::string> fetched;
  for (int first = 0; first < 7;) {
    auto page = keeper->Fetch("campus", run, first, 2500);
    ASSERT_TRUE(page.ok()) << page.status().ToString();
    ASSERT_FALSE(page->frames.empty());
    EXPECT_LE(page->frames.size(), 2u);
    for (const KeptFrame& f : page->frames) fetched.push_back(f.jpeg);
    first = page->next_frame;
  }
  ASSERT_EQ(fetched.size(), 7u);
  for (size_t i = 0; i < 7; ++i) EXPECT_EQ(fetched[i], bytes_[i]) << i;
  EXPECT_EQ(keeper->Fetch("campus", run, 8, 1).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(keeper->Fetch("campus", "nothing", 0, 1).status().code(), StatusCode::kNotFound);
}

TEST_F(FrameKeeperTest, RefusesWhatItCannotUse) {
  options_.dir = "";
  EXPECT_EQ(FrameKeeper::Open(options_).status().code(), StatusCode::kInvalidArgument);
  options_.dir = "/proc/sceneloc-cannot-be-made";
  const Status status = FrameKeeper::Open(options_).status();
  EXPECT_EQ(status.code(), StatusCode::kIoError) << status.ToString();
  EXPECT_NE(status.message().find("/proc/sceneloc-cannot-be-made"), std::string::npos);
  options_.dir = dir_.string();
  options_.min_unknown_frames = 0;
  EXPECT_EQ(FrameKeeper::Open(options_).status().code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(IsValidRunName("20261208T004026Z-rover_7"));
  for (const char* bad : {"", ".hidden", "a/b", "..", "a b"}) EXPECT_FALSE(IsValidRunName(bad));
}

}  // namespace
}  // namespace sceneloc
