// Map files on disk for the tests of map_io and its parts (common/map/map_io.h): the
// header's little-endian fields read and written by the tests themselves, so that they
// check the documented layout rather than trusting map_io's own reading of it, and a
// fixture with a folder to save and load files in.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/util/status.h"
#include "tests/support/scratch_dir.h"

namespace sceneloc::test {

// Little-endian integers at byte `at` of a file's bytes.
uint32_t GetU32(const std::string& b, size_t at);
uint64_t GetU64(const std::string& b, size_t at);
void PutU32(std::string* b, size_t at, uint32_t v);
void PutU64(std::string* b, size_t at, uint64_t v);

// Makes the header describe the (edited) payload again: size, payload CRC, header CRC.
void Rechecksum(std::string* b);

// A folder of the test's own (dir_) and the map path in it (path_, "tour.map").
class MapFileTest : public ::testing::Test {
 protected:
  MapFileTest();

  static void WriteBytes(const std::string& path, const std::string& bytes) {
    WriteFileBytes(path, bytes);
  }
  static std::string ReadBytes(const std::string& path) { return ReadFileBytes(path); }
  // The names in dir_, sorted.
  std::vector<std::string> DirectoryEntries() const { return test::DirectoryEntries(dir_); }
  // Writes `bytes` to the map path, loads it, and checks the status code and that the
  // message names the file and contains `expected`.
  void ExpectLoadFails(const std::string& bytes, StatusCode code, const std::string& expected);
  static void ExpectLoadFailsAt(const std::string& path, StatusCode code,
                                const std::string& expected);

  ScratchDir scratch_;
  std::filesystem::path dir_;
  std::string path_;
};

}  // namespace sceneloc::test
