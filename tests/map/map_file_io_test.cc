// The file system side of map files (common/map/map_file_io.h): atomic writes that leave
// nothing behind, and a streaming source that checksums what it delivers; (MapFileSaveTest) the
// same atomic writes as SaveMap makes them.
#include "common/map/map_file_io.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "common/map/crc32.h"
#include "common/map/map_io.h"
#include "tests/support/map_files.h"
#include "tests/support/test_map.h"

namespace sceneloc::map_io_internal {
namespace {

namespace fs = std::filesystem;

class MapFileIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) /
           ("map_file_io_test_" + std::to_string(::getpid()) + "_" + test->name());
    fs::remove_all(dir_);
    ASSERT_TRUE(fs::create_directories(dir_));
    path_ = (dir_ / "tour.scnl").string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::vector<std::string> Entries() const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(dir_)) {
      names.push_back(entry.path().filename().string());
    }
    return names;
  }
  static std::string ReadAll(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  static std::string RandomBytes(size_t n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::string bytes(n, '\0');
    for (char& c : bytes) c = static_cast<char>(rng());
    return bytes;
  }

  fs::path dir_;
  std::string path_;
};

// The file holds exactly the bytes written, and no temporary file is left beside it.
TEST_F(MapFileIoTest, WriteLeavesOnlyTheFile) {
  ASSERT_TRUE(WriteFileAtomically(path_, "first").ok());
  ASSERT_TRUE(WriteFileAtomically(path_, "second, longer").ok());
  EXPECT_EQ(ReadAll(path_), "second, longer");
  EXPECT_EQ(Entries(), std::vector<std::string>{"tour.scnl"});
}

// Into a folder that does not exist: IoError naming the temporary file; nothing made.
TEST_F(MapFileIoTest, WriteIntoMissingFolderFails) {
  const std::string path = (dir_ / "absent" / "tour.scnl").string();
  const Status status = WriteFileAtomically(path, "bytes");
  EXPECT_EQ(status.code(), StatusCode::kIoError);
  EXPECT_NE(status.message().find(path + ".tmp."), std::string::npos) << status.message();
  EXPECT_FALSE(fs::exists(dir_ / "absent"));
}

// When the rename fails (a folder holds the name) the temporary file is removed.
TEST_F(MapFileIoTest, FailedRenameRemovesTheTemporaryFile) {
  fs::create_directory(path_);
  const Status status = WriteFileAtomically(path_, "bytes");
  EXPECT_EQ(status.code(), StatusCode::kIoError);
  EXPECT_NE(status.message().find("cannot rename"), std::string::npos) << status.message();
  EXPECT_EQ(Entries(), std::vector<std::string>{"tour.scnl"});
}

// Small reads through the buffer, one read larger than it, and reads across its refills
// all deliver the file's bytes in order, with the CRC-32 of everything delivered.
TEST_F(MapFileIoTest, FileSourceDeliversTheFileInOrder) {
  const std::string bytes = RandomBytes(300 * 1024, 5);
  ASSERT_TRUE(WriteFileAtomically(path_, bytes).ok());
  const int fd = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  FdCloser closer(fd);
  FileSource source(fd, path_);
  std::string got;
  for (const size_t n : {size_t{3}, size_t{100 * 1024}, size_t{7}, size_t{60 * 1024},
                         size_t{70 * 1024}, size_t{1}}) {
    std::string piece(n, '\0');
    ASSERT_TRUE(source.Read(piece.data(), n).ok()) << "reading " << n;
    got += piece;
  }
  ASSERT_TRUE(source.Skip(bytes.size() - got.size()).ok());
  EXPECT_EQ(got, bytes.substr(0, got.size()));
  EXPECT_EQ(source.crc(), Crc32(bytes.data(), bytes.size()));
}

// Asking for more than the file holds is DataLoss "truncated", naming the file.
TEST_F(MapFileIoTest, FileSourceReportsAShortFile) {
  ASSERT_TRUE(WriteFileAtomically(path_, "short").ok());
  const int fd = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  FdCloser closer(fd);
  FileSource source(fd, path_);
  char out[16];
  const Status status = source.Read(out, sizeof(out));
  EXPECT_EQ(status.code(), StatusCode::kDataLoss);
  EXPECT_NE(status.message().find("'" + path_ + "' is truncated"), std::string::npos)
      << status.message();
}

// ReadPrefix reads what is there: all it was asked for, or the whole shorter file.
TEST_F(MapFileIoTest, ReadPrefixStopsAtTheEnd) {
  ASSERT_TRUE(WriteFileAtomically(path_, "0123456789").ok());
  const int fd = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  FdCloser closer(fd);
  char out[32];
  const StatusOr<size_t> first = ReadPrefix(fd, out, 4, path_);
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(*first, 4u);
  EXPECT_EQ(std::string(out, 4), "0123");
  const StatusOr<size_t> rest = ReadPrefix(fd, out, sizeof(out), path_);
  ASSERT_TRUE(rest.ok());
  EXPECT_EQ(*rest, 6u);
  EXPECT_EQ(std::string(out, 6), "456789");
}

}  // namespace
}  // namespace sceneloc::map_io_internal

namespace sceneloc {
namespace {

namespace fs = std::filesystem;
using test::ExpectMapsEqual;
using test::MakeRandomMap;

// SaveMap's writes, which WriteFileAtomically makes.
using MapFileSaveTest = test::MapFileTest;

// A successful save leaves only the map file: no temporary file behind.
TEST_F(MapFileSaveTest, SaveLeavesNoTemporaryFile) {
  ASSERT_TRUE(SaveMap(MakeRandomMap(5, 30, 1), path_).ok());
  EXPECT_EQ(DirectoryEntries(), std::vector<std::string>{"tour.map"});
}

// Saving over an existing map replaces it whole.
TEST_F(MapFileSaveTest, SaveReplacesExistingMap) {
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
TEST_F(MapFileSaveTest, SaveToMissingDirectoryFails) {
  const std::string path = (dir_ / "no_such_dir" / "tour.map").string();
  const Status status = SaveMap(MakeRandomMap(5, 30, 1), path);
  EXPECT_EQ(status.code(), StatusCode::kIoError) << status.ToString();
  EXPECT_NE(status.message().find(path), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("No such file or directory"), std::string::npos);
  EXPECT_TRUE(DirectoryEntries().empty());
}

// When the final rename fails (the target is a folder) the temporary file is removed.
TEST_F(MapFileSaveTest, FailedRenameRemovesTemporaryFile) {
  ASSERT_TRUE(fs::create_directory(path_));
  ASSERT_TRUE(fs::create_directory(fs::path(path_) / "occupied"));
  const Status status = SaveMap(MakeRandomMap(5, 30, 1), path_);
  EXPECT_EQ(status.code(), StatusCode::kIoError) << status.ToString();
  EXPECT_NE(status.message().find(path_), std::string::npos) << status.message();
  EXPECT_EQ(DirectoryEntries(), std::vector<std::string>{"tour.map"});
  EXPECT_TRUE(fs::is_directory(path_));
}

}  // namespace
}  // namespace sceneloc
