#include "tests/support/map_files.h"

#include "common/map/crc32.h"
#include "common/map/map_io.h"

namespace sceneloc::test {

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

void Rechecksum(std::string* b) {
  PutU64(b, 16, b->size() - kMapHeaderBytes);
  PutU32(b, 24, Crc32(b->data() + kMapHeaderBytes, b->size() - kMapHeaderBytes));
  PutU32(b, 28, Crc32(b->data(), 28));
}

MapFileTest::MapFileTest()
    : scratch_("map_file"), dir_(scratch_.path()), path_((dir_ / "tour.map").string()) {}

void MapFileTest::ExpectLoadFails(const std::string& bytes, StatusCode code,
                                  const std::string& expected) {
  WriteBytes(path_, bytes);
  ExpectLoadFailsAt(path_, code, expected);
}

void MapFileTest::ExpectLoadFailsAt(const std::string& path, StatusCode code,
                                    const std::string& expected) {
  const StatusOr<Map> loaded = LoadMap(path);
  ASSERT_FALSE(loaded.ok()) << "loading " << path << " should fail";
  const Status& status = loaded.status();
  EXPECT_EQ(status.code(), code) << status.ToString();
  EXPECT_NE(status.message().find("'" + path + "'"), std::string::npos) << status.message();
  EXPECT_NE(status.message().find(expected), std::string::npos) << status.message();
}

}  // namespace sceneloc::test
