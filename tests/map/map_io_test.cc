// SaveMap / LoadMap / ParseMap (common/map/map_io.h): round trips, the checks LoadMap
// makes itself (a missing or unreadable file, the size limit, the payload's checksum and
// the map's validity) and what the parts report through it. The header's errors are in
// map_header_test, atomic writes in map_file_io_test, hostile counts in
// payload_archive_test.
#include "common/map/map_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "common/map/crc32.h"
#include "tests/support/map_files.h"
#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;
using test::ExpectMapsEqual;
using test::GetU32;
using test::GetU64;
using test::MakeRandomMap;
using test::PutU32;
using test::PutU64;
using test::Rechecksum;

// A map whose every option differs from its default and from the others, so a
// serialiser that swapped or dropped a field would be caught.
Map MakeMapWithDistinctOptions() {
  Map map = MakeRandomMap(15, 120, 42);
  TrainOptions& o = map.options;
  o.extractor.max_features = 777;
  o.extractor.working_size = 481;
  o.extractor.context_scale = 2.5;
  o.extractor.contrast_threshold = 0.031;
  o.extractor.edge_threshold = 11.5;
  o.extractor.sigma = 1.7;
  o.extractor.octave_layers = 4;
  o.extractor.max_image_side = 4097;
  o.extractor.holistic.cell_pixels = 7;
  o.extractor.holistic.max_shift = 3;
  o.extractor.clahe_clip = 2.5;
  o.extractor.root_sift = true;
  o.track_distance_threshold = 0.55;
  o.ransac_threshold = 0.0047;
  o.ransac_confidence = 0.995;
  o.min_links_per_pair = 13;
  o.min_track_length = 3;
  o.min_landmarks_per_image = 41;
  o.local_var_floor = 0.021;
  o.context_var_floor = 0.0021;
  o.distance_sd_floor = 0.043;
  o.angle_var_floor = 0.011;
  o.quality_s_min = 0.31;
  o.quality_fp_prior = 1.1;
  o.eta = 9;
  o.q_min = 0.012;
  o.quality_window = 77;
  o.max_neighbours = 23;
  o.tolerance = 3;
  o.confidence_temperature = 0.29;
  o.map_evidence_slope = 1.7;
  o.map_evidence_offset = -0.4;
  map.provenance.num_features = 1001;
  map.provenance.num_tracks = 1002;
  map.provenance.num_candidates = 1003;
  // Two walks: the tour's 10 images, then 5 more views of places 3-7.
  map.image_place = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 3, 4, 5, 6, 7};
  map.experiences = {{"day", "/data/day", "2026-12-01T10:00:00Z", ExperienceKind::kTour, 0, 10, 10},
                     {"night",
                      "/data/night",
                      "2026-12-02T22:00:00Z",
                      ExperienceKind::kRoute,
                      10,
                      5,
                      12,
                      {true, 0.5f, 0.05f, 5}}};
  map.lookalike_offsets.clear();
  map.lookalike_location.clear();
  map.lookalike_ratio.clear();
  map.Finalize();
  return map;
}

// Save, load and parse through map_io's own entry points, in a folder of the test's own.
using MapIoTest = test::MapFileTest;

// Save then load gives back every field, and both report the same content checksum.
TEST_F(MapIoTest, RoundTripKeepsEveryField) {
  const Map map = MakeMapWithDistinctOptions();
  MapFileInfo saved;
  ASSERT_TRUE(SaveMap(map, path_, &saved).ok());
  MapFileInfo loaded_info;
  const StatusOr<Map> loaded = LoadMap(path_, &loaded_info);
  ASSERT_TRUE(loaded.ok()) << loaded.status().ToString();
  ExpectMapsEqual(map, *loaded);
  EXPECT_EQ(loaded_info.format_version, kMapFormatVersion);
  EXPECT_EQ(loaded_info.checksum, saved.checksum);
  EXPECT_EQ(loaded_info.payload_bytes, saved.payload_bytes);
  EXPECT_EQ(fs::file_size(path_), kMapHeaderBytes + saved.payload_bytes);
}

// A map with no landmarks (one image, empty arrays) round-trips too.
TEST_F(MapIoTest, RoundTripOfMapWithoutLandmarks) {
  const Map map = MakeRandomMap(1, 0, 5);
  ASSERT_TRUE(SaveMap(map, path_).ok());
  const StatusOr<Map> loaded = LoadMap(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status().ToString();
  ExpectMapsEqual(map, *loaded);
}

// The file is SerializeMap's bytes; ParseMap reads them; the checksum depends on the
// content only, and changes when the content does.
TEST_F(MapIoTest, SerializeAndParseAgreeWithFiles) {
  const Map map = MakeRandomMap(10, 80, 9);
  MapFileInfo saved;
  ASSERT_TRUE(SaveMap(map, path_, &saved).ok());
  const std::string bytes = SerializeMap(map);
  EXPECT_EQ(ReadBytes(path_), bytes);
  MapFileInfo parsed_info;
  const StatusOr<Map> parsed = ParseMap(bytes, "in memory", &parsed_info);
  ASSERT_TRUE(parsed.ok()) << parsed.status().ToString();
  ExpectMapsEqual(map, *parsed);
  EXPECT_EQ(parsed_info.checksum, saved.checksum);
  MapFileInfo other;
  ASSERT_TRUE(ParseMap(SerializeMap(MakeRandomMap(10, 80, 10)), "other", &other).ok());
  EXPECT_NE(other.checksum, saved.checksum);
}

// The header holds the documented fields at the documented offsets, and the payload
// starts with extractor.max_features.
TEST_F(MapIoTest, HeaderMatchesDocumentedLayout) {
  const Map map = MakeMapWithDistinctOptions();
  const std::string bytes = SerializeMap(map);
  ASSERT_GT(bytes.size(), kMapHeaderBytes);
  EXPECT_EQ(std::memcmp(bytes.data(), "SCNLMAP\0", 8), 0);
  EXPECT_EQ(GetU32(bytes, 8), kMapFormatVersion);
  EXPECT_EQ(GetU32(bytes, 12), 0u);
  EXPECT_EQ(GetU64(bytes, 16), bytes.size() - kMapHeaderBytes);
  EXPECT_EQ(GetU32(bytes, 24), Crc32(bytes.data() + 32, bytes.size() - 32));
  EXPECT_EQ(GetU32(bytes, 28), Crc32(bytes.data(), 28));
  EXPECT_EQ(GetU32(bytes, 32), 777u);
}

// An invalid map is refused before anything is written; an existing file is kept.
TEST_F(MapIoTest, SaveRefusesInvalidMap) {
  const Map good = MakeRandomMap(5, 30, 1);
  ASSERT_TRUE(SaveMap(good, path_).ok());
  const std::string before = ReadBytes(path_);
  Map bad = good;
  bad.image_landmarks[0] = 12345;
  const Status status = SaveMap(bad, path_);
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << status.ToString();
  EXPECT_NE(status.message().find("refers to landmark 12345"), std::string::npos);
  EXPECT_EQ(ReadBytes(path_), before);
  EXPECT_EQ(DirectoryEntries(), std::vector<std::string>{"tour.map"});
}

// A path with no file is NotFound.
TEST_F(MapIoTest, MissingFileIsNotFound) {
  ExpectLoadFailsAt(path_, StatusCode::kNotFound, "does not exist");
}

// A folder where the file should be is an IoError.
TEST_F(MapIoTest, DirectoryIsIoError) {
  ExpectLoadFailsAt(dir_.string(), StatusCode::kIoError, "not a regular file");
}

// A map written in format version 5 (tests/data/v5_map.scnl, before the context spreads
// and the neighbours' spreads were log codes) loads, its spreads coded as today's, and is
// saved again as today's, smaller.
TEST(MapIoCompatibilityTest, VersionFiveMapLoads) {
  MapFileInfo info;
  auto map = LoadMap(SCENELOC_TEST_DATA "/v5_map.scnl", &info);
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  EXPECT_EQ(info.format_version, 5u);
  EXPECT_EQ(map->num_images(), 6);
  EXPECT_EQ(map->options.eta, 30);
  ASSERT_FALSE(map->neighbours.empty());
  for (size_t k = 0; k < map->neighbours.size(); ++k) {
    const Neighbour n = map->NeighbourAt(k);
    ASSERT_GT(n.distance_var, 0);
    ASSERT_GT(n.angle_var, 0);
    // The training floors (distance sd 0.042 of the frame, angle variance 0.05), within
    // half a code's step.
    ASSERT_GE(std::sqrt(n.distance_var), 0.042 * map->frame_long_side() * 0.977) << k;
    ASSERT_GE(n.angle_var, 0.05 * 0.955) << k;
  }
  for (int g = 0; g < map->num_landmarks(); ++g) {
    for (int h = 0; h < kNumHistograms; ++h) ASSERT_GE(map->ContextVar(g, h), 0.016f * 0.96f);
  }
  const std::string bytes = SerializeMap(*map);
  EXPECT_EQ(GetU32(bytes, 8), kMapFormatVersion);
  EXPECT_LT(bytes.size(), std::filesystem::file_size(SCENELOC_TEST_DATA "/v5_map.scnl"));
  auto again = ParseMap(bytes, "resaved");
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  ExpectMapsEqual(*map, *again);
}

// A map written in format version 3 (tests/data/v3_map.scnl, before the quality window was
// stored) loads with a window of 0, the whole tour its Q was measured over, and is saved
// again as today's.
TEST(MapIoCompatibilityTest, VersionThreeMapLoads) {
  MapFileInfo info;
  auto map = LoadMap(SCENELOC_TEST_DATA "/v3_map.scnl", &info);
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  EXPECT_EQ(info.format_version, 3u);
  EXPECT_EQ(map->num_images(), 6);
  EXPECT_EQ(map->options.quality_window, 0);
  EXPECT_EQ(map->options.eta, 30);
  EXPECT_EQ(map->options.max_neighbours, 24);
  EXPECT_TRUE(map->calibration.valid);
  const std::string bytes = SerializeMap(*map);
  EXPECT_EQ(GetU32(bytes, 8), kMapFormatVersion);
  auto again = ParseMap(bytes, "resaved");
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  ExpectMapsEqual(*map, *again);
}

// A map written in format version 2 (tests/data/v2_map.scnl, before the octave layers
// were stored) loads with the 3 layers it was made with, and is saved again as today's.
TEST(MapIoCompatibilityTest, VersionTwoMapLoads) {
  MapFileInfo info;
  auto map = LoadMap(SCENELOC_TEST_DATA "/v2_map.scnl", &info);
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  EXPECT_EQ(info.format_version, 2u);
  EXPECT_EQ(map->num_images(), 6);
  EXPECT_EQ(map->options.extractor.octave_layers, 3);
  EXPECT_EQ(map->options.extractor.max_features, 100);
  EXPECT_EQ(map->options.eta, 30);
  EXPECT_TRUE(map->has_holistic());
  EXPECT_TRUE(map->calibration.valid);
  const std::string bytes = SerializeMap(*map);
  EXPECT_EQ(GetU32(bytes, 8), kMapFormatVersion);
  auto again = ParseMap(bytes, "resaved");
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  ExpectMapsEqual(*map, *again);
}

// A map written before format version 2 (tests/data/v1_map.scnl) loads in today's terms:
// its working frame is the frame it was made in, its pixel settings become fractions of
// it, and it has no holistic descriptors and no calibration.
TEST(MapIoCompatibilityTest, VersionOneMapLoads) {
  MapFileInfo info;
  auto map = LoadMap(SCENELOC_TEST_DATA "/v1_map.scnl", &info);
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  EXPECT_EQ(info.format_version, 1u);
  EXPECT_EQ(map->num_images(), 6);
  EXPECT_EQ(map->image_width, 320);
  EXPECT_EQ(map->image_height, 180);
  EXPECT_EQ(map->options.extractor.working_size, 320);
  EXPECT_DOUBLE_EQ(map->options.ransac_threshold, 2.0 / 320);
  EXPECT_NEAR(map->options.distance_sd_floor, 20.0 / 320, 1e-9);
  EXPECT_EQ(map->options.min_landmarks_per_image, 0);
  EXPECT_FALSE(map->has_holistic());
  EXPECT_FALSE(map->observation_angles);
  EXPECT_FALSE(map->calibration.valid);
  EXPECT_EQ(map->options.eta, 30);
  // Saved again, it is a version-2 file that loads the same.
  const std::string again = SerializeMap(*map);
  auto reloaded = ParseMap(again, "again", &info);
  ASSERT_TRUE(reloaded.ok()) << reloaded.status().ToString();
  EXPECT_EQ(info.format_version, kMapFormatVersion);
  test::ExpectMapsEqual(*map, *reloaded);
}

// One flipped bit anywhere in the payload is DataLoss "checksum mismatch ... (corrupt
// file)".
TEST_F(MapIoTest, FlippedPayloadBitIsChecksumMismatch) {
  const std::string good = SerializeMap(MakeRandomMap(10, 80, 3));
  for (size_t at : {kMapHeaderBytes, good.size() / 2, good.size() - 1}) {
    SCOPED_TRACE("byte " + std::to_string(at));
    std::string bytes = good;
    bytes[at] ^= 0x10;
    ExpectLoadFails(bytes, StatusCode::kDataLoss, "checksum mismatch");
    EXPECT_NE(LoadMap(path_).status().message().find("(corrupt file)"), std::string::npos);
  }
}

// A well-formed, correctly checksummed file whose map is inconsistent (a neighbour
// index out of range) is DataLoss from Validate, prefixed with the file name.
TEST_F(MapIoTest, OutOfRangeIndexIsDataLoss) {
  Map map = MakeRandomMap(10, 80, 3);
  ASSERT_FALSE(map.neighbours.empty());
  map.neighbours[0].landmark = 99999;
  ExpectLoadFails(SerializeMap(map), StatusCode::kDataLoss,
                  "map file '" + path_ +
                      "': neighbour 0 of landmark 0 refers to landmark 99999 "
                      "but the map has 80 landmarks");
}

// Bytes after the payload the header announces are DataLoss; so are payload bytes
// left over after the last field.
TEST_F(MapIoTest, TrailingBytesAreDataLoss) {
  const std::string good = SerializeMap(MakeRandomMap(4, 10, 3));
  ExpectLoadFails(good + "garbage", StatusCode::kDataLoss,
                  "has 7 unexpected bytes after the payload");
  std::string padded = good + "garbage";
  Rechecksum(&padded);
  ExpectLoadFails(padded, StatusCode::kDataLoss, "7 payload bytes follow the last field");
}

// A map file is untrusted: a huge file is refused from its header alone, before a byte
// of its payload is read or any memory is set aside for it. Sparse files, so the test
// needs neither the disk nor the time: 100 GB of zeros is "not a map", and a valid header
// announcing 100 GB of payload is above max_map_bytes.
TEST_F(MapIoTest, HugeFilesAreRefusedFromTheirHeader) {
  const uint64_t huge = uint64_t{100} << 30;
  const auto make_sparse = [&](const std::string& head) {
    WriteBytes(path_, head);
    ASSERT_EQ(::truncate(path_.c_str(), static_cast<off_t>(huge)), 0) << std::strerror(errno);
  };
  make_sparse(std::string(64, '\0'));
  ExpectLoadFailsAt(path_, StatusCode::kInvalidArgument, "bad magic");

  std::string header = SerializeMap(MakeRandomMap(4, 10, 3)).substr(0, kMapHeaderBytes);
  PutU64(&header, 16, huge - kMapHeaderBytes);  // payload bytes
  PutU32(&header, 28, Crc32(header.data(), 28));
  make_sparse(header);
  ExpectLoadFailsAt(path_, StatusCode::kResourceExhausted,
                    "is 107374182400 bytes (102400.0 MiB), above the limit max_map_bytes = "
                    "4294967296 bytes (4096.0 MiB)");
}

// The limit is the caller's: a real map above it is refused, at it loaded.
TEST_F(MapIoTest, MaxFileBytesIsTheCallersLimit) {
  const std::string bytes = SerializeMap(MakeRandomMap(4, 10, 3));
  WriteBytes(path_, bytes);
  MapLoadOptions tight;
  tight.max_file_bytes = bytes.size() - 1;
  const StatusOr<Map> refused = LoadMap(path_, nullptr, tight);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kResourceExhausted);
  EXPECT_NE(refused.status().message().find(std::to_string(bytes.size()) + " bytes"),
            std::string::npos)
      << refused.status().message();
  tight.max_file_bytes = bytes.size();
  EXPECT_TRUE(LoadMap(path_, nullptr, tight).ok());
}

// ParseMap names the source it was given in its errors.
TEST(ParseMapTest, ErrorsNameTheSource) {
  const StatusOr<Map> parsed = ParseMap("not a map at all", "upload from robot-3");
  ASSERT_FALSE(parsed.ok());
  EXPECT_EQ(parsed.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(parsed.status().message().find("map file 'upload from robot-3'"), std::string::npos)
      << parsed.status().message();
}

// Random damage to a payload that is then re-checksummed (so the parser and Validate,
// not the CRC, must cope) never crashes; whatever loads is valid.
TEST(ParseMapTest, SurvivesRandomDamageBehindValidChecksums) {
  const std::string good = SerializeMap(MakeRandomMap(6, 25, 3));
  std::mt19937 rng(1234);
  std::uniform_int_distribution<size_t> position(kMapHeaderBytes, good.size() - 1);
  int failures = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    std::string bytes = good;
    const int edits = 1 + trial % 4;
    for (int e = 0; e < edits; ++e) bytes[position(rng)] = static_cast<char>(rng());
    if (trial % 5 == 0) bytes.resize(position(rng));
    Rechecksum(&bytes);
    const StatusOr<Map> parsed = ParseMap(bytes, "fuzz");
    if (!parsed.ok()) {
      ++failures;
      EXPECT_EQ(parsed.status().code(), StatusCode::kDataLoss) << parsed.status().ToString();
    } else {
      EXPECT_TRUE(parsed->Validate().ok());
    }
  }
  EXPECT_GT(failures, 1000);  // most damage must be noticed
}

}  // namespace
}  // namespace sceneloc
