#include "common/util/file_io.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <iterator>
#include <string>

namespace sceneloc {
namespace {

TEST(FileIoTest, FilesAreWrittenWholeAndReadBack) {
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "file_io";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "frame.jpg").string();
  const std::string bytes("abc\0def", 7);
  ASSERT_TRUE(WriteFileAtomically(path, bytes).ok());
  auto back = ReadFileBytes(path);
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(*back, bytes);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir),
                          std::filesystem::directory_iterator()),
            1);  // no temporary left
  auto missing = ReadFileBytes((dir / "nothing.jpg").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), StatusCode::kNotFound);
  EXPECT_FALSE(ReadFileBytes(dir.string()).ok());  // a folder is not a file
  EXPECT_FALSE(WriteFileAtomically((dir / "no" / "such" / "folder.jpg").string(), "x").ok());
}

}  // namespace
}  // namespace sceneloc
