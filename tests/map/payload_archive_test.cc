// The field codec of map files (common/map/payload_archive.h): the documented byte layout
// of each field kind, round trips, and a reader that fails safely on hostile counts, here
// and (PayloadLoadTest) in a whole map file loaded with LoadMap.
#include "common/map/payload_archive.h"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "common/map/map_io.h"
#include "tests/support/map_files.h"
#include "tests/support/test_map.h"

namespace sceneloc::map_io_internal {
namespace {

using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;

// Little-endian bytes of an integer, written out by the test itself.
std::string Le(uint64_t v, int bytes) {
  std::string out;
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
  return out;
}

std::string FloatBytes(float f) {
  std::string out(sizeof(f), '\0');
  std::memcpy(out.data(), &f, sizeof(f));
  return out;
}

// A source whose every read fails, as a file that cannot be read would.
class FailingSource : public ByteSource {
 public:
  Status Read(void* /*out*/, size_t /*n*/) override { return IoError("disk on fire"); }
};

// Each field kind is laid out as payload_archive.h documents it.
TEST(PayloadArchiveTest, WriterFollowsTheDocumentedLayout) {
  std::string out;
  PayloadWriter writer(&out);
  writer.Field("i", int32_t{-2});
  writer.Field("b", true);
  writer.Field("s", std::string("ab"));
  writer.Field("names", std::vector<std::string>{"x"});
  writer.Field("v", std::vector<float>{1.5f});
  RowMatrix m(1, 3);
  m << 1, 2, 3;
  writer.Field("m", m);
  const std::string expected = Le(0xFFFFFFFEu, 4) + Le(1, 1) + Le(2, 8) + "ab" + Le(1, 8) +
                               Le(1, 8) + "x" + Le(1, 8) + FloatBytes(1.5f) + Le(1, 8) + Le(3, 8) +
                               FloatBytes(1) + FloatBytes(2) + FloatBytes(3);
  EXPECT_EQ(out, expected);
}

// What the writer wrote, the reader reads back, to the last byte.
TEST(PayloadArchiveTest, ReaderReadsBackWhatTheWriterWrote) {
  std::string bytes;
  PayloadWriter writer(&bytes);
  RowMatrix m(2, 3);
  m << 1, 2, 3, 4, 5, 6;
  writer.Field("d", 2.25);
  writer.Field("b", false);
  writer.Field("s", std::string("tour"));
  writer.Field("names", std::vector<std::string>{"a", "", "bcd"});
  writer.Field("v", std::vector<uint32_t>{7, 8, 9});
  writer.Field("m", m);

  MemorySource source(bytes.data());
  PayloadReader reader(&source, bytes.size());
  double d = 0;
  bool b = true;
  std::string s;
  std::vector<std::string> names;
  std::vector<uint32_t> v;
  RowMatrix read_m;
  reader.Field("d", d);
  reader.Field("b", b);
  reader.Field("s", s);
  reader.Field("names", names);
  reader.Field("v", v);
  reader.Field("m", read_m);
  ASSERT_TRUE(reader.status().ok()) << reader.status().ToString();
  EXPECT_EQ(reader.remaining(), 0u);
  EXPECT_EQ(d, 2.25);
  EXPECT_FALSE(b);
  EXPECT_EQ(s, "tour");
  EXPECT_EQ(names, (std::vector<std::string>{"a", "", "bcd"}));
  EXPECT_EQ(v, (std::vector<uint32_t>{7, 8, 9}));
  EXPECT_EQ(read_m, m);
}

// A count larger than the bytes left is DataLoss naming the field, and nothing is
// allocated for it (the vector stays empty).
TEST(PayloadArchiveTest, HugeCountFailsBeforeAllocating) {
  const std::string bytes = Le(uint64_t{1} << 60, 8) + std::string(16, '\0');
  MemorySource source(bytes.data());
  PayloadReader reader(&source, bytes.size());
  std::vector<float> v;
  reader.Field("quality", v);
  EXPECT_EQ(reader.status().code(), StatusCode::kDataLoss);
  EXPECT_NE(reader.status().message().find("quality"), std::string::npos);
  EXPECT_NE(reader.status().message().find("declares"), std::string::npos);
  EXPECT_TRUE(v.empty());
  EXPECT_EQ(v.capacity(), 0u);
}

// A bool stored as anything but 0 or 1 is DataLoss.
TEST(PayloadArchiveTest, BoolMustBeZeroOrOne) {
  const std::string bytes = Le(2, 1);
  MemorySource source(bytes.data());
  PayloadReader reader(&source, bytes.size());
  bool b = false;
  reader.Field("root_sift", b);
  EXPECT_EQ(reader.status().code(), StatusCode::kDataLoss);
  EXPECT_NE(reader.status().message().find("root_sift is 2, must be 0 or 1"), std::string::npos);
}

// A field past the end is DataLoss; the first failure sticks and later fields are left
// untouched.
TEST(PayloadArchiveTest, FirstFailureSticks) {
  const std::string bytes = Le(5, 2);  // two bytes: too few for a u32
  MemorySource source(bytes.data());
  PayloadReader reader(&source, bytes.size());
  uint32_t first = 77;
  uint8_t second = 66;
  reader.Field("first", first);
  reader.Field("second", second);
  EXPECT_EQ(reader.status().code(), StatusCode::kDataLoss);
  EXPECT_NE(reader.status().message().find("first"), std::string::npos);
  EXPECT_EQ(reader.status().message().find("second"), std::string::npos);
  EXPECT_EQ(first, 77u);
  EXPECT_EQ(second, 66);
  EXPECT_EQ(reader.remaining(), 2u);
}

// A matrix whose stored column count is not the type's is DataLoss.
TEST(PayloadArchiveTest, MatrixColumnCountMustMatch) {
  const std::string bytes = Le(1, 8) + Le(4, 8) + std::string(16, '\0');
  MemorySource source(bytes.data());
  PayloadReader reader(&source, bytes.size());
  RowMatrix m;
  reader.Field("context_mean", m);
  EXPECT_EQ(reader.status().code(), StatusCode::kDataLoss);
  EXPECT_NE(reader.status().message().find("4 columns, expected 3"), std::string::npos);
}

// A source's own error reaches status() unchanged (an IoError stays an IoError).
TEST(PayloadArchiveTest, SourceErrorsPassThrough) {
  FailingSource source;
  PayloadReader reader(&source, 8);
  uint64_t v = 0;
  reader.Field("payload", v);
  EXPECT_EQ(reader.status().code(), StatusCode::kIoError);
  EXPECT_EQ(reader.status().message(), "disk on fire");
}

}  // namespace
}  // namespace sceneloc::map_io_internal

namespace sceneloc {
namespace {

using test::MakeRandomMap;
using test::PutU64;
using test::Rechecksum;

// A hostile count in a whole map file, as LoadMap reports it.
using PayloadLoadTest = test::MapFileTest;

// A count far larger than the file (checksummed, so only a bad writer or an attacker
// makes it) is DataLoss, without trying to allocate for it.
TEST_F(PayloadLoadTest, HugeCountIsDataLossWithoutAllocating) {
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

}  // namespace
}  // namespace sceneloc
