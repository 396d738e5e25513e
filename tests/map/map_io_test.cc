// SaveMap / LoadMap / ParseMap: round trips, atomic writes, and one distinct error for
// each way a map file can be missing, cut short or corrupt.
#include "common/map/map_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "common/map/crc32.h"
#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;
using test::ExpectMapsEqual;
using test::MakeRandomMap;

// Little-endian header fields, read and written by the test itself so that it checks
// the documented layout rather than trusting map_io.cc.
uint32_t GetU32(const std::string& b, size_t at) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(b[at + i]);
  return v;
}

uint64_t GetU64(const std::string& b, size_t at) {
  return GetU32(b, at) | uint64_t{GetU32(b, at + 4)} << 32;
}

void PutU32(std::string* b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) (*b)[at + i] = static_cast<char>(v >> (8 * i));
}

void PutU64(std::string* b, size_t at, uint64_t v) {
  PutU32(b, at, static_cast<uint32_t>(v));
  PutU32(b, at + 4, static_cast<uint32_t>(v >> 32));
}

// Makes the header describe the (edited) payload again: size, payload CRC, header CRC.
void Rechecksum(std::string* b) {
  PutU64(b, 16, b->size() - kMapHeaderBytes);
  PutU32(b, 24, Crc32(b->data() + kMapHeaderBytes, b->size() - kMapHeaderBytes));
  PutU32(b, 28, Crc32(b->data(), 28));
}

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
  o.max_neighbours = 23;
  o.tolerance = 3;
  o.confidence_temperature = 0.29;
  o.map_evidence_slope = 1.7;
  o.map_evidence_offset = -0.4;
  map.provenance.num_features = 1001;
  map.provenance.num_tracks = 1002;
  map.provenance.num_candidates = 1003;
  return map;
}

class MapIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) /
           ("map_io_test_" + std::to_string(::getpid()) + "_" + test->name());
    fs::remove_all(dir_);
    ASSERT_TRUE(fs::create_directories(dir_));
    path_ = (dir_ / "tour.map").string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  static void WriteBytes(const std::string& path, const std::string& bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    ASSERT_TRUE(out.good()) << path;
  }
  static std::string ReadBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  std::vector<std::string> DirectoryEntries() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_)) {
      names.push_back(entry.path().filename().string());
    }
    return names;
  }
  // Writes `bytes` to the map path, loads it, and checks the status code and that the
  // message names the file and contains `expected`.
  void ExpectLoadFails(const std::string& bytes, StatusCode code, const std::string& expected) {
    WriteBytes(path_, bytes);
    ExpectLoadFailsAt(path_, code, expected);
  }
  static void ExpectLoadFailsAt(const std::string& path, StatusCode code,
                                const std::string& expected) {
    const StatusOr<Map> loaded = LoadMap(path);
    ASSERT_FALSE(loaded.ok()) << "loading " << path << " should fail";
    const Status& status = loaded.status();
    EXPECT_EQ(status.code(), code) << status.ToString();
    EXPECT_NE(status.message().find("'" + path + "'"), std::string::npos) << status.message();
    EXPECT_NE(status.message().find(expected), std::string::npos) << status.message();
  }

  fs::path dir_;
  std::string path_;
};

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

// A successful save leaves only the map file: no temporary file behind.
TEST_F(MapIoTest, SaveLeavesNoTemporaryFile) {
  ASSERT_TRUE(SaveMap(MakeRandomMap(5, 30, 1), path_).ok());
  EXPECT_EQ(DirectoryEntries(), std::vector<std::string>{"tour.map"});
}

// Saving over an existing map replaces it whole.
TEST_F(MapIoTest, SaveReplacesExistingMap) {
  ASSERT_TRUE(SaveMap(MakeRandomMap(5, 30, 1), path_).ok());
  const Map second = MakeRandomMap(6, 10, 2);
  ASSERT_TRUE(SaveMap(second, path_).ok());
  const StatusOr<Map> loaded = LoadMap(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status().ToString();
  ExpectMapsEqual(second, *loaded);
  EXPECT_EQ(DirectoryEntries(), std::vector<std::string>{"tour.map"});
}

// Saving into a folder that does not exist is an IoError naming the path, and creates
// nothing.
TEST_F(MapIoTest, SaveToMissingDirectoryFails) {
  const std::string path = (dir_ / "no_such_dir" / "tour.map").string();
  const Status status = SaveMap(MakeRandomMap(5, 30, 1), path);
  EXPECT_EQ(status.code(), StatusCode::kIoError) << status.ToString();
  EXPECT_NE(status.message().find(path), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("No such file or directory"), std::string::npos);
  EXPECT_TRUE(DirectoryEntries().empty());
}

// When the final rename fails (the target is a folder) the temporary file is removed.
TEST_F(MapIoTest, FailedRenameRemovesTemporaryFile) {
  ASSERT_TRUE(fs::create_directory(path_));
  ASSERT_TRUE(fs::create_directory(fs::path(path_) / "occupied"));
  const Status status = SaveMap(MakeRandomMap(5, 30, 1), path_);
  EXPECT_EQ(status.code(), StatusCode::kIoError) << status.ToString();
  EXPECT_NE(status.message().find(path_), std::string::npos) << status.message();
  EXPECT_EQ(DirectoryEntries(), std::vector<std::string>{"tour.map"});
  EXPECT_TRUE(fs::is_directory(path_));
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

// An empty file is DataLoss "is empty".
TEST_F(MapIoTest, EmptyFileIsDataLoss) { ExpectLoadFails("", StatusCode::kDataLoss, "is empty"); }

// A file cut anywhere, in the header or in the payload, is DataLoss "truncated" with
// the expected and the actual size.
TEST_F(MapIoTest, TruncatedFileIsDataLoss) {
  const std::string bytes = SerializeMap(MakeRandomMap(10, 80, 3));
  const size_t size = bytes.size();
  for (size_t cut : {size_t{1}, size_t{4}, size_t{8}, size_t{11}, size_t{12}, size_t{20},
                     size_t{31}, size_t{32}, size_t{33}, size / 2, size - 1}) {
    SCOPED_TRACE("cut at " + std::to_string(cut));
    const std::string expected_size = cut < kMapHeaderBytes ? "32" : std::to_string(size);
    ExpectLoadFails(
        bytes.substr(0, cut), StatusCode::kDataLoss,
        "is truncated: expected " + expected_size + " bytes, found " + std::to_string(cut));
  }
}

// A file that does not start with the magic is InvalidArgument "not a sceneloc map".
TEST_F(MapIoTest, WrongMagicIsInvalidArgument) {
  std::string bytes = SerializeMap(MakeRandomMap(4, 10, 3));
  bytes[3] = 'X';
  ExpectLoadFails(bytes, StatusCode::kInvalidArgument, "is not a sceneloc map (bad magic)");
  ExpectLoadFails("landmarks: []\n", StatusCode::kInvalidArgument, "bad magic");
  ExpectLoadFails("S", StatusCode::kDataLoss, "truncated");  // a prefix of the magic
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
  EXPECT_TRUE(map->observation_angle.empty());
  EXPECT_FALSE(map->calibration.valid);
  EXPECT_EQ(map->options.eta, 30);
  // Saved again, it is a version-2 file that loads the same.
  const std::string again = SerializeMap(*map);
  auto reloaded = ParseMap(again, "again", &info);
  ASSERT_TRUE(reloaded.ok()) << reloaded.status().ToString();
  EXPECT_EQ(info.format_version, kMapFormatVersion);
  test::ExpectMapsEqual(*map, *reloaded);
}

// A file of a newer format version (with a valid header CRC) is Unimplemented and
// says which versions this build reads.
TEST_F(MapIoTest, NewerFormatVersionIsUnimplemented) {
  for (uint32_t version : {kMapFormatVersion + 1, 77u}) {
    std::string bytes = SerializeMap(MakeRandomMap(4, 10, 3));
    PutU32(&bytes, 8, version);
    Rechecksum(&bytes);
    ExpectLoadFails(bytes, StatusCode::kUnimplemented,
                    "has format version " + std::to_string(version) + ", this build reads up to " +
                        std::to_string(kMapFormatVersion) + "; upgrade sceneloc");
  }
}

// Header flags this build does not know are Unimplemented.
TEST_F(MapIoTest, UnknownHeaderFlagsAreUnimplemented) {
  std::string bytes = SerializeMap(MakeRandomMap(4, 10, 3));
  PutU32(&bytes, 12, 1);
  Rechecksum(&bytes);
  ExpectLoadFails(bytes, StatusCode::kUnimplemented, "header flags 0x1");
}

// A damaged header (its CRC, or a field it covers) is DataLoss "header checksum
// mismatch".
TEST_F(MapIoTest, DamagedHeaderIsHeaderChecksumMismatch) {
  const std::string good = SerializeMap(MakeRandomMap(4, 10, 3));
  for (size_t at : {size_t{28}, size_t{31}, size_t{17}, size_t{25}}) {
    SCOPED_TRACE("byte " + std::to_string(at));
    std::string bytes = good;
    bytes[at] ^= 0x04;
    ExpectLoadFails(bytes, StatusCode::kDataLoss, "header checksum mismatch");
  }
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

// A count far larger than the file (checksummed, so only a bad writer or an attacker
// makes it) is DataLoss, without trying to allocate for it.
TEST_F(MapIoTest, HugeCountIsDataLossWithoutAllocating) {
  std::string bytes = SerializeMap(MakeRandomMap(4, 10, 3));
  const size_t name_at = bytes.find("frame_00000.jpg");
  ASSERT_NE(name_at, std::string::npos);
  // The image_names count precedes the first name's own length.
  PutU64(&bytes, name_at - 16, uint64_t{1} << 61);
  Rechecksum(&bytes);
  ExpectLoadFails(bytes, StatusCode::kDataLoss, "image_names at payload offset");
  PutU64(&bytes, name_at - 16, 4);
  PutU64(&bytes, name_at - 8, ~uint64_t{0});  // the name's length
  Rechecksum(&bytes);
  ExpectLoadFails(bytes, StatusCode::kDataLoss, "is malformed");
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
                    "1073741824 bytes (1024.0 MiB)");
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
