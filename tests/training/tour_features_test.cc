// The tour's features in memory and spooled to disk: a window reads back exactly the floats
// that went in, indexed by tour image.
#include "common/training/tour_features.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <random>

namespace sceneloc {
namespace {

FeatureSet RandomSet(int n, uint32_t seed, bool holistic) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  FeatureSet f;
  f.image_width = 480;
  f.image_height = 270;
  for (int i = 0; i < n; ++i) {
    f.keypoints.push_back({u(rng) * 100, u(rng) * 100, 3 + u(rng), 180 + 90 * u(rng), u(rng),
                           static_cast<int>(rng() % 7) - 1});
  }
  f.local = DescriptorMatrix::NullaryExpr(n, kDescriptorSize, [&] { return u(rng); });
  f.context = DescriptorMatrix::NullaryExpr(n, kDescriptorSize, [&] { return u(rng); });
  if (holistic) {
    f.holistic_grid = {4, 2, 3};
    for (int i = 0; i < f.holistic_grid.size(); ++i) f.holistic.push_back(u(rng));
  }
  return f;
}

void ExpectSame(const FeatureSet& a, const FeatureSet& b) {
  EXPECT_EQ(a.image_width, b.image_width);
  EXPECT_EQ(a.image_height, b.image_height);
  ASSERT_EQ(a.keypoints.size(), b.keypoints.size());
  for (size_t i = 0; i < a.keypoints.size(); ++i) {
    EXPECT_EQ(std::memcmp(&a.keypoints[i], &b.keypoints[i], sizeof(Keypoint)), 0) << i;
  }
  EXPECT_TRUE(a.local == b.local);
  EXPECT_TRUE(a.context == b.context);
  EXPECT_EQ(a.holistic_grid, b.holistic_grid);
  EXPECT_EQ(a.holistic, b.holistic);
}

// Windows of a spool read back every image as it was appended, wherever they start; images
// without features or without a holistic descriptor included.
TEST(FeatureSpoolTest, WindowsReadBackWhatWasAppended) {
  std::vector<FeatureSet> tour;
  for (int i = 0; i < 7; ++i) tour.push_back(RandomSet(i == 3 ? 0 : 5 + i, i, i != 5));
  auto spool = FeatureSpool::Create(::testing::TempDir());
  ASSERT_TRUE(spool.ok()) << spool.status().ToString();
  for (const FeatureSet& f : tour) ASSERT_TRUE((*spool)->Append(f).ok());
  EXPECT_EQ((*spool)->size(), tour.size());
  EXPECT_GT((*spool)->bytes(), 0u);
  for (const auto& [begin, end] : {std::pair<size_t, size_t>{0, 7}, {2, 5}, {6, 7}, {4, 4}}) {
    auto window = (*spool)->Window(begin, end);
    ASSERT_TRUE(window.ok()) << window.status().ToString();
    EXPECT_EQ(window->first(), begin);
    EXPECT_EQ(window->size(), end - begin);
    for (size_t i = begin; i < end; ++i) {
      SCOPED_TRACE("image " + std::to_string(i));
      EXPECT_TRUE(window->Holds(i));
      ExpectSame((*window)[i], tour[i]);
    }
    EXPECT_FALSE(window->Holds(end));
  }
}

// The spool leaves no file behind in its folder, even while it is open.
TEST(FeatureSpoolTest, LeavesNoFileInItsFolder) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "spool_dir";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  {
    auto spool = FeatureSpool::Create(dir.string());
    ASSERT_TRUE(spool.ok());
    ASSERT_TRUE((*spool)->Append(RandomSet(10, 1, true)).ok());
    EXPECT_TRUE(std::filesystem::is_empty(dir));
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir));
}

// A folder that does not exist is an IoError that names it.
TEST(FeatureSpoolTest, MissingFolderIsAnError) {
  auto spool = FeatureSpool::Create("/nonexistent/sceneloc");
  ASSERT_FALSE(spool.ok());
  EXPECT_EQ(spool.status().code(), StatusCode::kIoError);
  EXPECT_NE(spool.status().message().find("/nonexistent/sceneloc"), std::string::npos);
}

// A tour in memory hands out views of its own sets, indexed by tour image.
TEST(TourInMemoryTest, WindowsAreViews) {
  std::vector<FeatureSet> tour = {RandomSet(3, 1, true), RandomSet(4, 2, true),
                                  RandomSet(5, 3, true)};
  const TourInMemory memory(tour);
  auto window = memory.Window(1, 3);
  ASSERT_TRUE(window.ok());
  EXPECT_EQ(&(*window)[1], &tour[1]);
  EXPECT_EQ(&(*window)[2], &tour[2]);
  EXPECT_EQ(&WholeTour(tour)[0], &tour[0]);
}

}  // namespace
}  // namespace sceneloc
