// MapLoader: loads on the loader thread, the watched folder followed
// (new, replaced, bad, deleted and temporary files), bursts coalesced, SIGHUP's reload-all.
#include "server/map_loader.h"

#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <thread>

#include "common/map/map_io.h"
#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;
using test::kTestMapName;
constexpr std::chrono::seconds kWait(20);

// The test map with different provenance: a different file (and checksum), same places.
Map DifferentMap() {
  auto map = LoadMap(test::TestMapPath());
  EXPECT_TRUE(map.ok());
  map->provenance.tour_dir += "-replaced";
  return std::move(map).value();
}

class MapLoaderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(registry_.LoadDirectory(dir_.path(), nullptr).ok());
    ASSERT_NE(registry_.Get(kTestMapName), nullptr);
  }

  std::unique_ptr<MapLoader> StartLoader(bool watch, int debounce_ms = 20) {
    MapLoader::Options options;
    options.maps_dir = dir_.path();
    options.watch = watch;
    options.debounce = std::chrono::milliseconds(debounce_ms);
    auto loader = MapLoader::Start(options, &registry_);
    EXPECT_TRUE(loader.ok()) << loader.status().ToString();
    return loader.ok() ? std::move(loader).value() : nullptr;
  }

  uint64_t Generation(const std::string& map = kTestMapName) const {
    const auto loaded = registry_.Get(map);
    return loaded == nullptr ? 0 : loaded->generation;
  }

  test::TempMapsDir dir_{"loader"};
  MapRegistry registry_{MapRegistry::Options()};
};

// Reload runs on the loader thread and hands the result to `done`: the new snapshot, or
// the load's error with the old map still serving.
TEST_F(MapLoaderTest, ReloadRunsOnTheLoaderThreadAndReportsTheResult) {
  auto loader = StartLoader(/*watch=*/false);
  ASSERT_NE(loader, nullptr);
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<Status> results;
  std::vector<std::thread::id> threads;
  auto done = [&](const MapLoader::LoadResult* result) {
    std::lock_guard<std::mutex> lock(mutex);
    results.push_back(result == nullptr ? Internal("cancelled") : result->status());
    threads.push_back(std::this_thread::get_id());
    cv.notify_all();
  };
  ASSERT_EQ(loader->Reload(kTestMapName, done), MapLoader::Queued::kQueued);
  ASSERT_EQ(loader->Reload("absent", done), MapLoader::Queued::kQueued);
  std::unique_lock<std::mutex> lock(mutex);
  ASSERT_TRUE(cv.wait_for(lock, kWait, [&] { return results.size() == 2; }));
  EXPECT_TRUE(results[0].ok()) << results[0].ToString();
  EXPECT_EQ(results[1].code(), StatusCode::kNotFound);
  EXPECT_NE(threads[0], std::this_thread::get_id());
  EXPECT_EQ(threads[0], threads[1]);
  EXPECT_EQ(Generation(), 2u);
}

// A map file written in place or renamed into place is loaded; a new file becomes a new
// map; a deleted file unloads its map while a held snapshot stays usable; SaveMap's
// temporary file is never loaded.
TEST_F(MapLoaderTest, WatchFollowsNewReplacedAndDeletedFiles) {
  auto loader = StartLoader(/*watch=*/true);
  ASSERT_NE(loader, nullptr);

  fs::copy_file(dir_.MapPath(), dir_.MapPath("second"));
  ASSERT_TRUE(loader->WaitIdle(kWait));
  EXPECT_EQ(Generation("second"), 1u);

  MapFileInfo info;
  ASSERT_TRUE(SaveMap(DifferentMap(), dir_.MapPath(), &info).ok());  // tmp + rename
  ASSERT_TRUE(loader->WaitIdle(kWait));
  ASSERT_EQ(Generation(), 2u);
  EXPECT_EQ(registry_.Get(kTestMapName)->checksum, info.checksum);
  EXPECT_EQ(registry_.List().size(), 2u);  // no map named after the temporary file
  EXPECT_EQ(registry_.load_failures(), 0u);

  test::WriteInPlace(dir_.MapPath() + ".tmp.999", "half a map");
  ASSERT_TRUE(loader->WaitIdle(kWait));
  EXPECT_EQ(registry_.List().size(), 2u);
  EXPECT_EQ(registry_.load_failures(), 0u);

  const auto held = registry_.Get("second");
  fs::remove(dir_.MapPath("second"));
  ASSERT_TRUE(loader->WaitIdle(kWait));
  EXPECT_EQ(registry_.Get("second"), nullptr);
  EXPECT_EQ(registry_.unloads(), 1u);
  EXPECT_EQ(held->map.num_images(), test::kTestTourLocations);
}

// Garbage and a truncated file written over a served map fail to load, are counted, and
// change nothing; a good file afterwards loads.
TEST_F(MapLoaderTest, BadFilesChangeNothing) {
  auto loader = StartLoader(/*watch=*/true);
  ASSERT_NE(loader, nullptr);
  const std::string good = test::ReadFile(dir_.MapPath());
  const uint32_t checksum = registry_.Get(kTestMapName)->checksum;

  test::WriteInPlace(dir_.MapPath(), "not a map at all");
  ASSERT_TRUE(loader->WaitIdle(kWait));
  EXPECT_EQ(registry_.load_failures(), 1u);
  test::WriteInPlace(dir_.MapPath(), good.substr(0, good.size() / 2));
  ASSERT_TRUE(loader->WaitIdle(kWait));
  EXPECT_EQ(registry_.load_failures(), 2u);
  ASSERT_EQ(Generation(), 1u);
  EXPECT_EQ(registry_.Get(kTestMapName)->checksum, checksum);

  test::WriteInPlace(dir_.MapPath(), good);
  ASSERT_TRUE(loader->WaitIdle(kWait));
  EXPECT_EQ(Generation(), 2u);
  EXPECT_EQ(registry_.load_failures(), 2u);
}

// Several writes of one file in quick succession load it once, after the last.
TEST_F(MapLoaderTest, BurstsOfEventsAreCoalesced) {
  auto loader = StartLoader(/*watch=*/true, /*debounce_ms=*/500);
  ASSERT_NE(loader, nullptr);
  const std::string good = test::ReadFile(dir_.MapPath());
  test::WriteInPlace(dir_.MapPath(), "garbage first");
  for (int i = 0; i < 4; ++i) test::WriteInPlace(dir_.MapPath(), good);
  ASSERT_TRUE(loader->WaitIdle(kWait));
  EXPECT_EQ(Generation(), 2u);
  EXPECT_EQ(registry_.loads(), 2u);  // the start-up load and one reload
  EXPECT_EQ(registry_.load_failures(), 0u);
}

// ReloadAll (SIGHUP) reloads every file, loads new ones and unloads maps whose file is
// gone, without a watch.
TEST_F(MapLoaderTest, ReloadAllFollowsTheFolder) {
  fs::copy_file(dir_.MapPath(), dir_.MapPath("second"));
  ASSERT_TRUE(registry_.Load(dir_.MapPath("second")).ok());
  auto loader = StartLoader(/*watch=*/false);
  ASSERT_NE(loader, nullptr);
  fs::remove(dir_.MapPath("second"));
  fs::copy_file(dir_.MapPath(), dir_.MapPath("third"));
  loader->ReloadAll();
  ASSERT_TRUE(loader->WaitIdle(kWait));
  EXPECT_EQ(Generation(), 2u);
  EXPECT_EQ(Generation("second"), 0u);
  EXPECT_EQ(Generation("third"), 1u);
  EXPECT_EQ(registry_.unloads(), 1u);
}

// Stop with reloads queued: every `done` is called exactly once, with a result for the
// ones started and null for the rest.
TEST_F(MapLoaderTest, StopAnswersEveryQueuedReload) {
  auto loader = StartLoader(/*watch=*/false);
  ASSERT_NE(loader, nullptr);
  std::atomic<int> loaded{0}, cancelled{0};
  int queued = 0;
  for (const std::string map : {kTestMapName, "absent", "other"}) {
    for (int i = 0; i < 5; ++i) {
      queued += loader->Reload(map, [&](const MapLoader::LoadResult* result) {
        ++(result == nullptr ? cancelled : loaded);
      }) == MapLoader::Queued::kQueued;
    }
  }
  EXPECT_EQ(queued, 15);
  loader->Stop();
  EXPECT_EQ(loaded + cancelled, queued);
}

// A flood of reloads (the 20,000 in half a second) coalesces into a few loads,
// refuses what is beyond the bound with kOverloaded, answers every accepted caller
// exactly once, and never keeps the watched folder waiting: a map dropped in during the
// flood is served within seconds.
TEST_F(MapLoaderTest, FloodOfReloadsCoalescesAndIsBounded) {
  auto loader = StartLoader(/*watch=*/true);
  ASSERT_NE(loader, nullptr);
  std::atomic<int> answered{0};
  std::atomic<bool> stop{false};
  int accepted = 0, overloaded = 0;
  std::thread flood([&] {
    while (!stop) {
      const MapLoader::Queued q = loader->Reload(kTestMapName, [&](const MapLoader::LoadResult* r) {
        EXPECT_NE(r, nullptr);
        ++answered;
      });
      (q == MapLoader::Queued::kQueued ? accepted : overloaded)++;
    }
  });
  const uint64_t loads_before = registry_.loads();
  const auto dropped_in = std::chrono::steady_clock::now();
  ASSERT_TRUE(SaveMap(DifferentMap(), dir_.MapPath("annex")).ok());
  while (registry_.Get("annex") == nullptr &&
         std::chrono::steady_clock::now() - dropped_in < std::chrono::seconds(10)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const auto waited = std::chrono::steady_clock::now() - dropped_in;
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  stop = true;
  flood.join();
  ASSERT_TRUE(loader->WaitIdle(kWait));
  EXPECT_NE(registry_.Get("annex"), nullptr) << "the new map waited behind the flood";
  EXPECT_LT(waited, std::chrono::seconds(5));
  EXPECT_GT(overloaded, 0);
  EXPECT_EQ(answered.load(), accepted);
  // Each load answers up to 16 waiting callers: far fewer loads than accepted reloads.
  EXPECT_LT(registry_.loads() - loads_before, static_cast<uint64_t>(accepted));
}

// The maps folder renamed away and a new one moved into its place: the loader notices,
// watches the new folder, serves its maps and unloads the ones it no longer holds.
TEST_F(MapLoaderTest, FolderReplacedIsWatchedAgainAndRescanned) {
  MapLoader::Options options;
  options.maps_dir = dir_.path();
  options.debounce = std::chrono::milliseconds(20);
  options.rewatch_interval = std::chrono::milliseconds(50);
  auto started = MapLoader::Start(options, &registry_);
  ASSERT_TRUE(started.ok()) << started.status().ToString();
  std::unique_ptr<MapLoader> loader = std::move(started).value();
  const std::string old_dir = dir_.path() + ".old", new_dir = dir_.path() + ".new";
  fs::remove_all(old_dir);
  fs::remove_all(new_dir);
  fs::create_directories(new_dir);
  ASSERT_TRUE(SaveMap(DifferentMap(), (fs::path(new_dir) / "fresh.scnl").string()).ok());
  fs::rename(dir_.path(), old_dir);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the loader sees the loss
  fs::rename(new_dir, dir_.path());
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while ((registry_.Get("fresh") == nullptr || registry_.Get(kTestMapName) != nullptr) &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_NE(registry_.Get("fresh"), nullptr) << "the new folder's map was not loaded";
  EXPECT_EQ(registry_.Get(kTestMapName), nullptr) << "a map the folder no longer holds serves";
  // And the new folder is watched: a file dropped into it is loaded.
  ASSERT_TRUE(SaveMap(DifferentMap(), dir_.MapPath("later")).ok());
  ASSERT_TRUE(loader->WaitIdle(kWait));
  EXPECT_NE(registry_.Get("later"), nullptr);
  loader->Stop();
  fs::remove_all(old_dir);
}

// After Stop, Reload refuses (done is never called) and WaitIdle returns false.
TEST_F(MapLoaderTest, StopRefusesNewWork) {
  auto loader = StartLoader(/*watch=*/true);
  ASSERT_NE(loader, nullptr);
  loader->Stop();
  bool called = false;
  EXPECT_EQ(loader->Reload(kTestMapName, [&](const MapLoader::LoadResult*) { called = true; }),
            MapLoader::Queued::kStopping);
  EXPECT_FALSE(called);
  EXPECT_FALSE(loader->WaitIdle(std::chrono::milliseconds(100)));
  loader->Stop();  // idempotent
}

}  // namespace
}  // namespace sceneloc
