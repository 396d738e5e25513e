// The map file header (common/map/map_header.h): written at the documented offsets, read
// back, and one distinct error for each way a header can be wrong, on bytes made here and
// (MapHeaderLoadTest) on whole map files loaded with LoadMap.
#include "common/map/map_header.h"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <string>

#include "common/map/crc32.h"
#include "tests/support/map_files.h"
#include "tests/support/test_map.h"

namespace sceneloc::map_io_internal {
namespace {

// A whole file: a header written for `payload`, then the payload.
std::string FileWith(const std::string& payload) {
  std::string file(kMapHeaderBytes, '\0');
  WriteHeader(payload.size(), Crc32(payload.data(), payload.size()), file.data());
  return file + payload;
}

// Re-seals the header CRC after a test edited the header.
void ResealHeader(std::string* file) {
  PutU32(Crc32(file->data(), kHeaderCrcOffset), file->data() + kHeaderCrcOffset);
}

// Expects ParseHeader to fail on `file` with `code`, naming the file and saying `expected`.
void ExpectHeaderFails(const std::string& file, StatusCode code, const std::string& expected) {
  const StatusOr<MapFileInfo> info = ParseHeader(file.data(), file.size(), "lab.scnl");
  ASSERT_FALSE(info.ok());
  EXPECT_EQ(info.status().code(), code) << info.status().ToString();
  EXPECT_NE(info.status().message().find("map file 'lab.scnl'"), std::string::npos)
      << info.status().message();
  EXPECT_NE(info.status().message().find(expected), std::string::npos) << info.status().message();
}

// Integers are stored little-endian, least significant byte first.
TEST(MapHeaderTest, IntegersAreLittleEndian) {
  char bytes[8];
  PutU32(0x01020304u, bytes);
  EXPECT_EQ(std::string(bytes, 4), std::string("\x04\x03\x02\x01", 4));
  PutU64(0x1122334455667788ull, bytes);
  EXPECT_EQ(GetU64(bytes), 0x1122334455667788ull);
  EXPECT_EQ(GetU32(bytes + 4), 0x11223344u);
}

// WriteHeader puts magic, version, flags, payload size and both CRCs at their offsets.
TEST(MapHeaderTest, WriteHeaderFollowsTheDocumentedLayout) {
  const std::string file = FileWith("payload!");
  EXPECT_EQ(std::memcmp(file.data(), "SCNLMAP\0", 8), 0);
  EXPECT_EQ(GetU32(file.data() + kVersionOffset), kMapFormatVersion);
  EXPECT_EQ(GetU32(file.data() + kFlagsOffset), 0u);
  EXPECT_EQ(GetU64(file.data() + kPayloadBytesOffset), 8u);
  EXPECT_EQ(GetU32(file.data() + kPayloadCrcOffset), Crc32("payload!", 8));
  EXPECT_EQ(GetU32(file.data() + kHeaderCrcOffset), Crc32(file.data(), 28));
}

// ParseHeader reads back what WriteHeader wrote.
TEST(MapHeaderTest, ParseHeaderReadsWhatWasWritten) {
  const std::string file = FileWith("0123456789");
  const StatusOr<MapFileInfo> info = ParseHeader(file.data(), file.size(), "lab.scnl");
  ASSERT_TRUE(info.ok()) << info.status().ToString();
  EXPECT_EQ(info->format_version, kMapFormatVersion);
  EXPECT_EQ(info->payload_bytes, 10u);
  EXPECT_EQ(info->checksum, Crc32("0123456789", 10));
}

// Empty, foreign and cut-short files each get their own error.
TEST(MapHeaderTest, EmptyForeignAndShortFiles) {
  ExpectHeaderFails("", StatusCode::kDataLoss, "is empty");
  ExpectHeaderFails("GIF89a-not-a-map-at-all-but-long-enough-to-be-one",
                    StatusCode::kInvalidArgument, "bad magic");
  const std::string file = FileWith("abc");
  ExpectHeaderFails(file.substr(0, 10), StatusCode::kDataLoss, "expected 32 bytes, found 10");
  ExpectHeaderFails(file.substr(0, 20), StatusCode::kDataLoss, "expected 32 bytes, found 20");
}

// A newer version is Unimplemented even when its header CRC does not check out (a newer
// header may be laid out differently); version 0 is corruption.
TEST(MapHeaderTest, VersionIsCheckedBeforeTheHeaderChecksum) {
  std::string file = FileWith("abc");
  PutU32(kMapFormatVersion + 1, file.data() + kVersionOffset);
  ExpectHeaderFails(file, StatusCode::kUnimplemented, "reads up to");
  PutU32(0, file.data() + kVersionOffset);
  ResealHeader(&file);
  ExpectHeaderFails(file, StatusCode::kDataLoss, "invalid format version 0");
}

// A header field changed after sealing is a header checksum mismatch; unknown flags with
// a valid CRC are Unimplemented.
TEST(MapHeaderTest, DamagedHeaderAndUnknownFlags) {
  std::string file = FileWith("abc");
  file[kPayloadCrcOffset] ^= 1;
  ExpectHeaderFails(file, StatusCode::kDataLoss, "header checksum mismatch");
  file = FileWith("abc");
  PutU32(4, file.data() + kFlagsOffset);
  ResealHeader(&file);
  ExpectHeaderFails(file, StatusCode::kUnimplemented, "header flags 0x4");
}

// The payload must be exactly what follows the header: less is truncated (with the size
// the header announced), more is "unexpected bytes".
TEST(MapHeaderTest, PayloadSizeMustMatchTheFile) {
  const std::string file = FileWith("abcdef");
  ExpectHeaderFails(file.substr(0, file.size() - 2), StatusCode::kDataLoss,
                    "expected 38 bytes, found 36");
  ExpectHeaderFails(file + "xyz", StatusCode::kDataLoss, "3 unexpected bytes after the payload");
}

// A payload size near 2^64 is reported without overflowing the expected file size.
TEST(MapHeaderTest, HugePayloadSizeDoesNotOverflow) {
  std::string file = FileWith("");
  PutU64(std::numeric_limits<uint64_t>::max(), file.data() + kPayloadBytesOffset);
  ResealHeader(&file);
  ExpectHeaderFails(file, StatusCode::kDataLoss,
                    "expected " + std::to_string(std::numeric_limits<uint64_t>::max()) + " bytes");
}

}  // namespace
}  // namespace sceneloc::map_io_internal

namespace sceneloc {
namespace {

using test::MakeRandomMap;
using test::PutU32;
using test::Rechecksum;

// The header's errors as LoadMap reports them for a file on disk.
using MapHeaderLoadTest = test::MapFileTest;

// An empty file is DataLoss "is empty".
TEST_F(MapHeaderLoadTest, EmptyFileIsDataLoss) {
  ExpectLoadFails("", StatusCode::kDataLoss, "is empty");
}

// A file cut anywhere, in the header or in the payload, is DataLoss "truncated" with
// the expected and the actual size.
TEST_F(MapHeaderLoadTest, TruncatedFileIsDataLoss) {
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
TEST_F(MapHeaderLoadTest, WrongMagicIsInvalidArgument) {
  std::string bytes = SerializeMap(MakeRandomMap(4, 10, 3));
  bytes[3] = 'X';
  ExpectLoadFails(bytes, StatusCode::kInvalidArgument, "is not a sceneloc map (bad magic)");
  ExpectLoadFails("landmarks: []\n", StatusCode::kInvalidArgument, "bad magic");
  ExpectLoadFails("S", StatusCode::kDataLoss, "truncated");  // a prefix of the magic
}

// A file of a newer format version (with a valid header CRC) is Unimplemented and
// says which versions this build reads.
TEST_F(MapHeaderLoadTest, NewerFormatVersionIsUnimplemented) {
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
TEST_F(MapHeaderLoadTest, UnknownHeaderFlagsAreUnimplemented) {
  std::string bytes = SerializeMap(MakeRandomMap(4, 10, 3));
  PutU32(&bytes, 12, 1);
  Rechecksum(&bytes);
  ExpectLoadFails(bytes, StatusCode::kUnimplemented, "header flags 0x1");
}

// A damaged header (its CRC, or a field it covers) is DataLoss "header checksum
// mismatch".
TEST_F(MapHeaderLoadTest, DamagedHeaderIsHeaderChecksumMismatch) {
  const std::string good = SerializeMap(MakeRandomMap(4, 10, 3));
  for (size_t at : {size_t{28}, size_t{31}, size_t{17}, size_t{25}}) {
    SCOPED_TRACE("byte " + std::to_string(at));
    std::string bytes = good;
    bytes[at] ^= 0x04;
    ExpectLoadFails(bytes, StatusCode::kDataLoss, "header checksum mismatch");
  }
}

}  // namespace
}  // namespace sceneloc
