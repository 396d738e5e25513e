// Listing image folders (common/util/image_folder.h): file-name order, hidden files and
// folders skipped, one distinct error for each unusable folder.
#include "common/util/image_folder.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

class ImageFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) /
           ("image_folder_test_" + std::to_string(::getpid()) + "_" + test->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  void Touch(const std::string& name) const { std::ofstream(dir_ / name) << "x"; }

  fs::path dir_;
};

// Regular files come back in file-name order with their folder; hidden files and
// sub-folders are left out.
TEST_F(ImageFolderTest, ListsRegularFilesInNameOrder) {
  Touch("Image010.jpg");
  Touch("Image002.jpg");
  Touch(".hidden.jpg");
  fs::create_directory(dir_ / "sub");
  const StatusOr<std::vector<std::string>> files = ListImageFiles(dir_.string());
  ASSERT_TRUE(files.ok()) << files.status().ToString();
  EXPECT_EQ(*files, (std::vector<std::string>{(dir_ / "Image002.jpg").string(),
                                              (dir_ / "Image010.jpg").string()}));
}

// A missing folder is NotFound, a file is InvalidArgument, an empty folder is
// FailedPrecondition; each names the path.
TEST_F(ImageFolderTest, UnusableFoldersEachHaveTheirError) {
  const std::string missing = (dir_ / "absent").string();
  EXPECT_EQ(ListImageFiles(missing).status().code(), StatusCode::kNotFound);
  Touch("file.jpg");
  const std::string file = (dir_ / "file.jpg").string();
  EXPECT_EQ(ListImageFiles(file).status().code(), StatusCode::kInvalidArgument);
  fs::create_directory(dir_ / "empty");
  const StatusOr<std::vector<std::string>> empty = ListImageFiles((dir_ / "empty").string());
  EXPECT_EQ(empty.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(empty.status().message().find((dir_ / "empty").string()), std::string::npos);
}

// Numbered frames are listed in the order they were taken, padded or not: a generated tour
// of more than 1,000 locations (Image999.jpg, Image1000.jpg) or a camera's frame9, frame10.
TEST_F(ImageFolderTest, NumberedFramesComeInTheirOrder) {
  for (const char* name : {"Image1000.jpg", "Image999.jpg", "Image100.jpg", "Image10000.jpg"}) {
    Touch(name);
  }
  const StatusOr<std::vector<std::string>> files = ListImageFiles(dir_.string());
  ASSERT_TRUE(files.ok()) << files.status().ToString();
  std::vector<std::string> names;
  for (const std::string& f : *files) names.push_back(FileName(f));
  EXPECT_EQ(names, (std::vector<std::string>{"Image100.jpg", "Image999.jpg", "Image1000.jpg",
                                             "Image10000.jpg"}));
}

TEST(NaturalLessTest, NumbersCompareByValueAndTheRestByByte) {
  EXPECT_TRUE(NaturalLess("frame9.jpg", "frame10.jpg"));
  EXPECT_FALSE(NaturalLess("frame10.jpg", "frame9.jpg"));
  EXPECT_TRUE(NaturalLess("a2b3", "a2b10"));
  EXPECT_TRUE(NaturalLess("a.jpg", "b.jpg"));
  EXPECT_TRUE(NaturalLess("x", "x1"));  // a prefix first
  EXPECT_FALSE(NaturalLess("x1", "x"));
  EXPECT_TRUE(NaturalLess("Image099.jpg", "Image100.jpg"));
  // Equal numbers written differently: one fixed order, never both ways.
  EXPECT_NE(NaturalLess("f007", "f7"), NaturalLess("f7", "f007"));
  EXPECT_FALSE(NaturalLess("same", "same"));
}

// FileName keeps the last path component only.
TEST(FileNameTest, KeepsTheLastComponent) {
  EXPECT_EQ(FileName("/a/b/Image042.jpg"), "Image042.jpg");
  EXPECT_EQ(FileName("Image042.jpg"), "Image042.jpg");
  EXPECT_EQ(FileName("rel/dir/x.png"), "x.png");
}

}  // namespace
}  // namespace sceneloc
