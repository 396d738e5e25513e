// The experiment runner's feature cache (tools/eval/feature_cache.h) on real JPEG files of a
// generated tour: an entry is written once and read back instead of extracting, its key is
// the folder listing (names, sizes and modification times), the extractor settings and the
// frame, and an entry that fails its checks is a miss that is rebuilt.
#include "tools/eval/feature_cache.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "common/util/image_folder.h"
#include "tests/support/scratch_dir.h"
#include "tests/support/tour_features.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

class FeatureCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    images_ = (dir_.path() / "tour").string();
    cache_ = (dir_.path() / "cache" / "features").string();
    ASSERT_TRUE(WriteTour(test::SmallTour(3), images_, kTrainingPass).ok());
    const auto paths = ListImageFiles(images_);
    ASSERT_TRUE(paths.ok());
    paths_ = *paths;
    options_.working_size = 320;
    options_.max_features = 300;
  }

  StatusOr<std::vector<FeatureSet>> Extract(const std::string& cache_dir,
                                            const ExtractionTarget* frame = nullptr) const {
    return ExtractCached(paths_, options_, cache_dir, 1, frame);
  }
  // The cache's entries: its files, but for temporary ones (which must not be left).
  std::vector<std::string> Entries() const {
    std::vector<std::string> entries = test::DirectoryEntries(cache_);
    for (const std::string& name : entries) {
      EXPECT_EQ(fs::path(name).extension(), ".features") << name;
    }
    return entries;
  }
  // Features extracted afresh, without the cache.
  std::vector<FeatureSet> Fresh(const ExtractionTarget* frame = nullptr) const {
    auto sets = Extract("", frame);
    EXPECT_TRUE(sets.ok()) << sets.status().ToString();
    return sets.ok() ? *sets : std::vector<FeatureSet>();
  }
  static void ExpectSame(const std::vector<FeatureSet>& a, const std::vector<FeatureSet>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) test::ExpectFeatureSetsEqual(a[i], b[i]);
  }

  const test::ScratchDir dir_{"feature_cache"};
  std::string images_, cache_;
  std::vector<std::string> paths_;
  ExtractorOptions options_;
};

// The first call creates the cache folder and one entry holding what extraction gives; a
// later call reads it and does not extract: with every image replaced by as many bytes of
// garbage (which cannot be extracted), it still returns the same features.
TEST_F(FeatureCacheTest, AnEntryIsReadInsteadOfExtracting) {
  const auto first = Extract(cache_);
  ASSERT_TRUE(first.ok()) << first.status().ToString();
  ASSERT_EQ(first->size(), 3u);
  ExpectSame(*first, Fresh());
  ASSERT_EQ(Entries().size(), 1u);

  for (const std::string& path : paths_) {
    const auto mtime = fs::last_write_time(path);  // the key holds it: keep it
    test::WriteFileBytes(path, std::string(fs::file_size(path), 'x'));
    fs::last_write_time(path, mtime);
  }
  EXPECT_FALSE(Extract("").ok()) << "the garbage images can be extracted: the test proves nothing";
  const auto cached = Extract(cache_);
  ASSERT_TRUE(cached.ok()) << cached.status().ToString();
  ExpectSame(*cached, *first);
  EXPECT_EQ(Entries().size(), 1u);
}

// Other extractor settings, another list of images, a query frame, or an image of another
// size each make an entry of their own; the first entry still serves its own call.
TEST_F(FeatureCacheTest, SettingsListingFrameAndSizesKeyTheEntry) {
  ASSERT_TRUE(Extract(cache_).ok());
  options_.max_features = 200;
  ASSERT_TRUE(Extract(cache_).ok());
  EXPECT_EQ(Entries().size(), 2u);
  options_.max_features = 300;

  ASSERT_TRUE(ExtractCached({paths_[0], paths_[1]}, options_, cache_, 1).ok());
  EXPECT_EQ(Entries().size(), 3u);

  ExtractionTarget frame;
  frame.width = 480;
  frame.height = 270;
  const auto queries = Extract(cache_, &frame);
  ASSERT_TRUE(queries.ok()) << queries.status().ToString();
  EXPECT_EQ(queries->front().image_width, 480);  // extracted in the map's frame
  EXPECT_EQ(Entries().size(), 4u);

  test::WriteFileBytes(paths_[2], test::ReadFileBytes(paths_[2]) + '\0');  // one byte longer
  ASSERT_TRUE(Extract(cache_).ok());
  EXPECT_EQ(Entries().size(), 5u);
}

// An image replaced by another of the same size is a miss: the key holds each file's
// modification time. (Both images are first padded to one size; JPEG ignores what follows
// its end marker.)
TEST_F(FeatureCacheTest, AnImageReplacedByOneOfTheSameSizeIsAMiss) {
  std::string first = test::ReadFileBytes(paths_[0]), second = test::ReadFileBytes(paths_[1]);
  const size_t size = std::max(first.size(), second.size());
  first.resize(size, '\0');
  second.resize(size, '\0');
  test::WriteFileBytes(paths_[0], first);
  test::WriteFileBytes(paths_[1], second);
  ASSERT_TRUE(Extract(cache_).ok());
  ASSERT_EQ(Entries().size(), 1u);
  const auto mtime = fs::last_write_time(paths_[1]);
  test::WriteFileBytes(paths_[1], first);
  fs::last_write_time(paths_[1], mtime + std::chrono::seconds(10));
  const auto replaced = Extract(cache_);
  ASSERT_TRUE(replaced.ok()) << replaced.status().ToString();
  EXPECT_EQ(Entries().size(), 2u);
  test::ExpectFeatureSetsEqual((*replaced)[1], (*replaced)[0]);  // the new image's features
}

// A truncated entry, one of another cache version and one of garbage are each a miss: the
// features are extracted again, equal to a fresh extraction, and the entry rewritten whole.
TEST_F(FeatureCacheTest, ADamagedEntryIsRebuilt) {
  ASSERT_TRUE(Extract(cache_).ok());
  ASSERT_EQ(Entries().size(), 1u);
  const std::string entry = (fs::path(cache_) / Entries().front()).string();
  const std::string good = test::ReadFileBytes(entry);
  ASSERT_GT(good.size(), 100u);
  std::string other_version = good;
  other_version[0] = static_cast<char>(other_version[0] + 1);
  const std::vector<FeatureSet> fresh = Fresh();
  std::string flipped = good;  // one bit of one descriptor: only the checksum sees it
  flipped[good.size() / 2] = static_cast<char>(flipped[good.size() / 2] ^ 0x10);
  for (const std::string& damaged :
       {good.substr(0, good.size() / 2), good.substr(0, 6), other_version, flipped,
        good + "trailing", std::string(good.size(), '\xff')}) {
    test::WriteFileBytes(entry, damaged);
    const auto rebuilt = Extract(cache_);
    ASSERT_TRUE(rebuilt.ok()) << rebuilt.status().ToString();
    ExpectSame(*rebuilt, fresh);
    EXPECT_EQ(test::ReadFileBytes(entry), good);
  }
}

// An entry made for other images, renamed to this listing's entry name (what a hash
// collision would look like), is a miss: the entry holds its whole key.
TEST_F(FeatureCacheTest, AnEntryOfAnotherKeyIsAMiss) {
  ASSERT_TRUE(ExtractCached({paths_[0], paths_[1], paths_[0]}, options_, cache_, 1).ok());
  ASSERT_EQ(Entries().size(), 1u);
  const fs::path foreign = fs::path(cache_) / Entries().front();
  const std::string foreign_bytes = test::ReadFileBytes(foreign.string());
  ASSERT_TRUE(Extract(cache_).ok());
  ASSERT_EQ(Entries().size(), 2u);
  const std::vector<std::string> names = Entries();
  const fs::path own = fs::path(cache_) / (names[0] == foreign.filename() ? names[1] : names[0]);
  test::WriteFileBytes(own.string(), foreign_bytes);
  const auto read = Extract(cache_);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ExpectSame(*read, Fresh());
}

// When the entry cannot be written (its name is taken by a folder), the features are still
// returned and no temporary file is left behind.
TEST_F(FeatureCacheTest, AnEntryThatCannotBeWrittenLeavesNothing) {
  ASSERT_TRUE(Extract(cache_).ok());
  const fs::path entry = fs::path(cache_) / Entries().front();
  fs::remove(entry);
  fs::create_directory(entry);
  fs::create_directory(entry / "occupied");  // a non-empty folder: rename cannot replace it
  const auto sets = Extract(cache_);
  ASSERT_TRUE(sets.ok()) << sets.status().ToString();
  ExpectSame(*sets, Fresh());
  EXPECT_EQ(test::DirectoryEntries(cache_), std::vector<std::string>{entry.filename().string()});
}

// The folder form lists the images in name order and returns their file names; a missing
// folder is an error naming it, whether or not there is a cache.
TEST_F(FeatureCacheTest, FolderFormNamesTheImages) {
  std::vector<std::string> names;
  const auto sets = ExtractFolderCached(images_, options_, cache_, 1, &names);
  ASSERT_TRUE(sets.ok()) << sets.status().ToString();
  EXPECT_EQ(names,
            (std::vector<std::string>{TourImageName(0), TourImageName(1), TourImageName(2)}));
  ExpectSame(*sets, Fresh());
  const std::string missing = (dir_.path() / "absent").string();
  const auto none = ExtractFolderCached(missing, options_, cache_, 1, &names);
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.status().code(), StatusCode::kNotFound);
  EXPECT_NE(none.status().message().find(missing), std::string::npos);
}

// Without a cache folder nothing is written beside the images.
TEST_F(FeatureCacheTest, NoCacheFolderWritesNothing) {
  ASSERT_TRUE(Extract("").ok());
  EXPECT_FALSE(fs::exists(dir_.path() / "cache"));
  EXPECT_EQ(test::DirectoryEntries(dir_.path()), std::vector<std::string>{"tour"});
  EXPECT_EQ(test::DirectoryEntries(images_).size(), 3u);
}

}  // namespace
}  // namespace sceneloc
