// MapRegistry: generations, snapshots that outlive swaps and removals, failed loads that
// change nothing.
#include "server/map_registry.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "common/map/crc32.h"
#include "common/map/map_io.h"
#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

class MapRegistryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("sceneloc_registry_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    path_ = (dir_ / "site.scnl").string();
    fs::copy_file(test::TestMapPath(), path_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Overwrites the map file with its first `bytes` bytes.
  void Truncate(size_t bytes) {
    std::string content(bytes, '\0');
    std::ifstream(path_, std::ios::binary)
        .read(content.data(), static_cast<std::streamsize>(bytes));
    std::ofstream(path_, std::ios::binary | std::ios::trunc)
        .write(content.data(), static_cast<std::streamsize>(bytes));
  }

  MapRegistry registry_{MapRegistry::Options()};
  fs::path dir_;
  std::string path_;
};

// A load serves the file under its stem with generation 1 and the file's checksum.
TEST_F(MapRegistryTest, LoadServesUnderTheFileStem) {
  auto loaded = registry_.Load(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status().ToString();
  MapFileInfo info;
  ASSERT_TRUE(LoadMap(path_, &info).ok());
  const auto map = registry_.Get("site");
  ASSERT_NE(map, nullptr);
  EXPECT_EQ(map->generation, 1u);
  EXPECT_EQ(map->checksum, info.checksum);
  EXPECT_EQ(map->path, path_);
  EXPECT_NE(map->extractor, nullptr);
  EXPECT_EQ(registry_.Get("other"), nullptr);
  EXPECT_EQ(registry_.loads(), 1u);
}

// A reload swaps in generation 2 while a held snapshot stays generation 1 and usable.
TEST_F(MapRegistryTest, ReloadSwapsWhileOldSnapshotLives) {
  ASSERT_TRUE(registry_.Load(path_).ok());
  const auto held = registry_.Get("site");
  ASSERT_TRUE(registry_.Load(path_).ok());
  EXPECT_EQ(registry_.Get("site")->generation, 2u);
  EXPECT_EQ(held->generation, 1u);
  EXPECT_EQ(held->map.num_images(), test::kTestTourLocations);
  EXPECT_NE(held, registry_.Get("site"));
}

// A truncated or garbage replacement fails, is counted, and the old map keeps serving.
TEST_F(MapRegistryTest, BadReplacementLeavesOldMapServing) {
  ASSERT_TRUE(registry_.Load(path_).ok());
  Truncate(fs::file_size(path_) / 2);
  auto truncated = registry_.Load(path_);
  EXPECT_EQ(truncated.status().code(), StatusCode::kDataLoss) << truncated.status().ToString();
  std::ofstream(path_, std::ios::trunc) << "not a map";
  EXPECT_FALSE(registry_.Load(path_).ok());
  fs::remove(path_);
  EXPECT_EQ(registry_.Load(path_).status().code(), StatusCode::kNotFound);
  ASSERT_NE(registry_.Get("site"), nullptr);
  EXPECT_EQ(registry_.Get("site")->generation, 1u);
  EXPECT_EQ(registry_.load_failures(), 3u);
}

// Remove stops serving, a held snapshot survives, and a later load continues the count.
TEST_F(MapRegistryTest, RemoveKeepsHeldSnapshotsAndGenerationsGrow) {
  ASSERT_TRUE(registry_.Load(path_).ok());
  const auto held = registry_.Get("site");
  EXPECT_TRUE(registry_.Remove("site"));
  EXPECT_FALSE(registry_.Remove("site"));
  EXPECT_EQ(registry_.Get("site"), nullptr);
  EXPECT_TRUE(registry_.List().empty());
  EXPECT_EQ(held->map.num_images(), test::kTestTourLocations);
  ASSERT_TRUE(registry_.Load(path_).ok());
  EXPECT_EQ(registry_.Get("site")->generation, 2u);
}

// LoadDirectory loads every *.scnl, reports each failure, and ignores other files.
TEST_F(MapRegistryTest, LoadDirectoryReportsEachFailure) {
  fs::copy_file(path_, dir_ / "second.scnl");
  std::ofstream(dir_ / "broken.scnl") << "broken";
  std::ofstream(dir_ / "notes.txt") << "not a map";
  std::vector<Status> failures;
  ASSERT_TRUE(registry_.LoadDirectory(dir_.string(), &failures).ok());
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_NE(failures[0].message().find("broken.scnl"), std::string::npos);
  ASSERT_EQ(registry_.List().size(), 2u);
  EXPECT_EQ(registry_.List()[0]->name, "second");
  EXPECT_FALSE(registry_.LoadDirectory((dir_ / "absent").string(), nullptr).ok());
}

// Files in the maps folder are untrusted: a 100 GB sparse file of zeros and a valid header
// announcing 100 GB are each refused from their header, fast and without memory, while the
// good map is served; entries that are not maps are named once, so "serving 0 maps" never
// leaves an operator guessing; SaveMap's temporary files and hidden files are not.
TEST_F(MapRegistryTest, HostileFilesAreSkippedAndOtherEntriesNamed) {
  const off_t huge = off_t{100} << 30;
  std::ofstream(dir_ / "zeros.scnl") << std::string(64, '\0');
  ASSERT_EQ(::truncate((dir_ / "zeros.scnl").c_str(), huge), 0);
  std::string header(kMapHeaderBytes, '\0');
  std::ifstream(path_, std::ios::binary).read(header.data(), kMapHeaderBytes);
  const uint64_t payload = static_cast<uint64_t>(huge) - kMapHeaderBytes;
  std::memcpy(header.data() + 16, &payload, 8);
  const uint32_t crc = Crc32(header.data(), 28);
  std::memcpy(header.data() + 28, &crc, 4);
  std::ofstream(dir_ / "announces.scnl", std::ios::binary) << header;
  ASSERT_EQ(::truncate((dir_ / "announces.scnl").c_str(), huge), 0);
  std::ofstream(dir_ / "lab.map") << "a map by another name";
  std::ofstream(dir_ / ".hidden") << "x";
  std::ofstream(dir_ / "next.scnl.tmp.123") << "being written";

  std::vector<Status> failures;
  std::vector<std::string> ignored;
  const auto start = std::chrono::steady_clock::now();
  ASSERT_TRUE(registry_.LoadDirectory(dir_.string(), &failures, &ignored).ok());
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
  ASSERT_EQ(failures.size(), 2u);
  EXPECT_EQ(failures[0].code(), StatusCode::kResourceExhausted) << failures[0].ToString();
  EXPECT_NE(failures[0].message().find("max_map_bytes"), std::string::npos);
  EXPECT_EQ(failures[1].code(), StatusCode::kInvalidArgument) << failures[1].ToString();
  EXPECT_EQ(ignored, std::vector<std::string>{"lab.map"});
  ASSERT_EQ(registry_.List().size(), 1u);
  EXPECT_EQ(registry_.List()[0]->name, "site");
  EXPECT_EQ(registry_.load_failures(), 2u);
}

// The self-test query of every location of the test map ranks that location among the
// best (the contract Load checks), and a shuffled map fails it.
TEST_F(MapRegistryTest, SelfTestFeaturesFindTheirLocation) {
  auto map = LoadMap(path_);
  ASSERT_TRUE(map.ok());
  for (int l = 0; l < map->num_images(); ++l) {
    auto result = Localise(SelfTestFeatures(*map, l), *map, MatchOptions(), nullptr);
    ASSERT_TRUE(result.ok());
    const auto& ranked = result->ranked;
    EXPECT_TRUE(std::any_of(ranked.begin(), ranked.end(),
                            [&](const RankedLocation& r) { return r.index == l; }))
        << "location " << l;
  }
}

// The self-test query carries each landmark's observed position and keypoint size in its
// location, so the engine's geometric and scale verification puts that location first
// (with a fixed size the scale check pushed it down and real maps failed to load).
TEST_F(MapRegistryTest, SelfTestFeaturesRankTheirLocationFirst) {
  auto map = LoadMap(path_);
  ASSERT_TRUE(map.ok());
  for (int l = 0; l < map->num_images(); ++l) {
    const FeatureSet f = SelfTestFeatures(*map, l);
    for (size_t i = 0; i < f.keypoints.size(); ++i) {
      const uint32_t g = map->image_landmarks[map->image_offsets[l] + i];
      bool seen = false;
      for (uint32_t o = map->observation_offsets[g]; o < map->observation_offsets[g + 1]; ++o) {
        if (map->observation_image[o] != static_cast<uint32_t>(l)) continue;
        EXPECT_EQ(f.keypoints[i].size, map->ObservationSize(o));
        seen = true;
      }
      EXPECT_TRUE(seen);
    }
    auto result = Localise(f, *map, MatchOptions(), nullptr);
    ASSERT_TRUE(result.ok());
    EXPECT_EQ(result->ranked[0].index, l);
  }
}

}  // namespace
}  // namespace sceneloc
