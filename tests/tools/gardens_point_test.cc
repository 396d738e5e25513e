// Real images: train on the first 60 locations of Gardens Point day_left with the shipped
// settings, localise day_right 000-059, and hold a match-rate floor. Skipped when
// ../shared/data/gardens_point is not beside the checkout.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/config/config.h"
#include "common/features/extractor.h"
#include "common/matching/baseline.h"
#include "common/matching/localiser.h"
#include "common/training/trainer.h"
#include "common/util/image_folder.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

constexpr int kLocations = 60;

std::vector<std::string> FirstImages(const std::string& dir, int n) {
  auto files = ListImageFiles(dir);
  EXPECT_TRUE(files.ok());
  std::vector<std::string> first(files->begin(),
                                 files->begin() + std::min<size_t>(n, files->size()));
  return first;
}

// Our match rate within ±2 frames on 60 real locations stays above a floor and above the
// baseline's on the same features.
TEST(GardensPointTest, MatchRateFloorOnSixtyLocations) {
  const std::string root = SCENELOC_GARDENS_POINT;
  if (!fs::is_directory(root + "/day_left") || !fs::is_directory(root + "/day_right")) {
    GTEST_SKIP() << root << " is not present";
  }
  TrainOptions train;
  ASSERT_TRUE(LoadTrainOptions(std::string(SCENELOC_CONFIGS_DIR) + "/train.yaml", &train).ok());
  MatchOptions match;
  ASSERT_TRUE(LoadMatchOptions(std::string(SCENELOC_CONFIGS_DIR) + "/match.yaml", &match).ok());

  const auto tour_paths = FirstImages(root + "/day_left", kLocations);
  const auto query_paths = FirstImages(root + "/day_right", kLocations);
  ASSERT_EQ(tour_paths.size(), static_cast<size_t>(kLocations));
  auto tour = ExtractFolder(tour_paths, train.extractor, 2, nullptr);
  auto queries = ExtractFolder(query_paths, train.extractor, 2, nullptr);
  ASSERT_TRUE(tour.ok() && queries.ok());
  std::vector<std::string> names;
  for (const auto& p : tour_paths) names.push_back(FileName(p));
  auto trained = TrainFromFeatures(*tour, names, train, 2, nullptr);
  ASSERT_TRUE(trained.ok()) << trained.status().ToString();

  auto baseline = VotingBaseline::Build(*tour, {});
  ASSERT_TRUE(baseline.ok());
  ThreadPool pool(2);
  int ours = 0, theirs = 0;
  for (int q = 0; q < kLocations; ++q) {
    auto r = Localise((*queries)[q], trained->map, match, &pool);
    ASSERT_TRUE(r.ok());
    ours += std::abs(r->ranked[0].index - q) <= 2;
    theirs += std::abs((*baseline)->Localise((*queries)[q]).best - q) <= 2;
  }
  const double rate = double(ours) / kLocations, baseline_rate = double(theirs) / kLocations;
  std::printf("gardens point, %d locations: ±2 match rate %.3f (baseline %.3f)\n", kLocations, rate,
              baseline_rate);
  EXPECT_GE(rate, SCENELOC_GP_FLOOR);
  EXPECT_GT(rate, baseline_rate);
}

}  // namespace
}  // namespace sceneloc
