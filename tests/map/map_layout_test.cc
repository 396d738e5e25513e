// The payload layout of map files (common/map/map_layout.h): both format versions walked
// by a writer and a reader, the order of the first fields, and the version-1 upgrade.
#include "common/map/map_layout.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "common/map/map_io.h"
#include "common/map/payload_archive.h"
#include "tests/support/test_map.h"

namespace sceneloc::map_io_internal {
namespace {

std::string Write(const Map& map, uint32_t version, const V1Fields& v1 = {}) {
  std::string bytes;
  PayloadWriter writer(&bytes);
  TransferMap(writer, map, version, v1);
  return bytes;
}

// Reads `bytes` as a payload of `version`; expects every byte used.
Map Read(const std::string& bytes, uint32_t version, V1Fields* v1) {
  MemorySource source(bytes.data());
  PayloadReader reader(&source, bytes.size());
  Map map;
  TransferMap(reader, map, version, *v1);
  EXPECT_TRUE(reader.status().ok()) << reader.status().ToString();
  EXPECT_EQ(reader.remaining(), 0u);
  return map;
}

// A version-2 payload read back gives every stored field of the map written.
TEST(MapLayoutTest, VersionTwoRoundTrips) {
  Map map = test::MakeRandomMap(6, 40, 3);
  map.options.quality_window = 0;  // what version 2 (and 3) maps were made with
  map.options.place_index_min_locations = 0;
  V1Fields unused;
  Map read = Read(Write(map, 2), 2, &unused);
  read.Finalize();
  test::ExpectMapsEqual(map, read);
}

// Version 5 stores the context spreads as binary16 and neighbours in 16 bytes: read back,
// they are coded as today's map holds them, the same codes.
TEST(MapLayoutTest, VersionFiveRoundTrips) {
  Map map = test::MakeRandomMap(6, 40, 3);
  V1Fields unused;
  const std::string v5 = Write(map, 5);
  EXPECT_GT(v5.size(), Write(map, kMapFormatVersion).size());
  Map read = Read(v5, 5, &unused);
  read.Finalize();
  // Version 5 kept the distances' spreads in steps of 1/32768 of the frame: they come back
  // within that step or one of their code's, the others as they were.
  ASSERT_EQ(read.neighbours.size(), map.neighbours.size());
  const float step = NeighbourDistanceCode().step() - 1;
  const float unit = static_cast<float>(map.frame_long_side()) / 32768;
  for (size_t k = 0; k < map.neighbours.size(); ++k) {
    const Neighbour a = map.NeighbourAt(k), b = read.NeighbourAt(k);
    EXPECT_EQ(a.distance_mean, b.distance_mean);
    const float sd = std::sqrt(a.distance_var);
    EXPECT_NEAR(std::sqrt(b.distance_var), sd, std::max(sd * step, unit) * 1.001f);
    EXPECT_NEAR(b.distance_dmax, a.distance_dmax, std::max(a.distance_dmax * step, unit) * 1.001f);
    EXPECT_EQ(a.angle_mean, b.angle_mean);
    EXPECT_EQ(a.angle_var, b.angle_var);
    EXPECT_EQ(a.cooccurrence, b.cooccurrence);
  }
  read.neighbours = map.neighbours;
  test::ExpectMapsEqual(map, read);
}

// The current version stores every option, the SIFT octave layers too (version 3).
TEST(MapLayoutTest, CurrentVersionRoundTrips) {
  Map map = test::MakeRandomMap(6, 40, 3);
  map.options.extractor.octave_layers = 5;
  V1Fields unused;
  Map read = Read(Write(map, kMapFormatVersion), kMapFormatVersion, &unused);
  read.Finalize();
  test::ExpectMapsEqual(map, read);
}

// Version 2 has no octave layers (its maps were all made with 3): four bytes shorter, and
// read back with the default whatever the map in memory said.
TEST(MapLayoutTest, VersionTwoLeavesOutTheOctaveLayers) {
  Map map = test::MakeRandomMap(4, 20, 6);
  map.options.extractor.octave_layers = 5;
  const std::string v2_bytes = Write(map, 2);
  EXPECT_EQ(v2_bytes.size() + sizeof(int32_t), Write(map, 3).size());
  V1Fields unused;
  const Map read = Read(v2_bytes, 2, &unused);
  EXPECT_EQ(read.options.extractor.octave_layers, ExtractorOptions().octave_layers);
  EXPECT_EQ(read.options.extractor.octave_layers, 3);
  EXPECT_EQ(read.options.extractor.sigma, map.options.extractor.sigma);
  EXPECT_EQ(read.options.extractor.max_image_side, map.options.extractor.max_image_side);
}

// Version 3 has neither the quality window nor the place index: read back, the window is the
// whole tour (0), the map was made without an index and has none.
TEST(MapLayoutTest, VersionThreeLeavesOutTheWindowAndThePlaceIndex) {
  Map map = test::MakeRandomMap(4, 20, 6);
  map.options.quality_window = 64;
  const std::string v3_bytes = Write(map, 3);
  EXPECT_LT(v3_bytes.size(), Write(map, 4).size());
  V1Fields unused;
  const Map read = Read(v3_bytes, 3, &unused);
  EXPECT_EQ(read.options.quality_window, 0);
  EXPECT_EQ(read.options.place_index_min_locations, 0);
  EXPECT_FALSE(read.has_place_index());
  EXPECT_EQ(read.options.eta, map.options.eta);
}

// The payload starts with extractor.max_features (i32), then working_size (i32), then
// context_scale (f64), as map_io.h documents.
TEST(MapLayoutTest, PayloadStartsWithTheExtractorOptions) {
  Map map = test::MakeRandomMap(2, 5, 4);
  map.options.extractor.max_features = 1234;
  map.options.extractor.working_size = 321;
  map.options.extractor.context_scale = 2.75;
  const std::string bytes = Write(map, 2);
  int32_t max_features = 0, working_size = 0;
  double context_scale = 0;
  std::memcpy(&max_features, bytes.data(), 4);
  std::memcpy(&working_size, bytes.data() + 4, 4);
  std::memcpy(&context_scale, bytes.data() + 8, 8);
  EXPECT_EQ(max_features, 1234);
  EXPECT_EQ(working_size, 321);
  EXPECT_EQ(context_scale, 2.75);
}

// Version 1 stores the old pixel settings in place of today's and leaves out the fields
// added later: it is shorter, and reading it gives back the old settings.
TEST(MapLayoutTest, VersionOneStoresTheOldFields) {
  const Map map = test::MakeRandomMap(4, 20, 5);
  const V1Fields old{1.0, 2.5, 400.0};
  const std::string v1_bytes = Write(map, 1, old);
  EXPECT_LT(v1_bytes.size(), Write(map, 2).size());
  V1Fields read_old;
  const Map read = Read(v1_bytes, 1, &read_old);
  EXPECT_EQ(read_old.image_scale, 1.0);
  EXPECT_EQ(read_old.ransac_threshold_px, 2.5);
  EXPECT_EQ(read_old.distance_var_floor, 400.0);
  EXPECT_EQ(read.image_names, map.image_names);
  EXPECT_FALSE(read.observation_angles);
  EXPECT_FALSE(read.calibration.valid);
}

// UpgradeV1 makes the frame the map was made in its working frame and turns pixel
// settings into fractions of its long side.
TEST(MapLayoutTest, UpgradeV1ConvertsPixelsToFractionsOfTheFrame) {
  Map map;
  map.image_width = 640;
  map.image_height = 480;
  map.options.extractor.holistic.cols = 16;
  map.options.min_landmarks_per_image = 40;
  UpgradeV1(V1Fields{1.0, 2.0, 400.0}, &map);
  EXPECT_EQ(map.options.extractor.working_size, 640);
  EXPECT_DOUBLE_EQ(map.options.ransac_threshold, 2.0 / 640);
  EXPECT_DOUBLE_EQ(map.options.distance_sd_floor, 20.0 / 640);
  EXPECT_EQ(map.options.extractor.holistic.cols, 0);
  EXPECT_EQ(map.options.min_landmarks_per_image, 0);
}

// A negative variance floor (a corrupt but checksummed file) becomes 0, not NaN.
TEST(MapLayoutTest, UpgradeV1FloorsNegativeVariance) {
  Map map;
  map.image_width = 320;
  map.image_height = 180;
  UpgradeV1(V1Fields{1.0, 1.0, -5.0}, &map);
  EXPECT_EQ(map.options.distance_sd_floor, 0.0);
}

}  // namespace
}  // namespace sceneloc::map_io_internal
