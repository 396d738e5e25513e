// Real images, when ../shared/data is beside the checkout (skipped otherwise): small slices
// of the accuracy suite (tools/eval/accuracy_suite.h) with the shipped settings. Each holds
// a floor on the match rate within ±2 frames and beats both baselines on the same features.
// The floors sit below what the full sets measure (docs/results.md) to leave room for the
// smaller slices and platform differences in SIFT and RANSAC, not for a regression.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/config/config.h"
#include "tools/eval/accuracy_suite.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

struct Slice {
  const char* set;  // a set of DevelopmentSuite
  int tour_limit;
  int query_limit;
  double floor;  // ±2 match rate
};

class RealDataTest : public ::testing::TestWithParam<Slice> {};

// Ours above the floor and above the better baseline on one slice.
TEST_P(RealDataTest, FloorAndAboveBaselines) {
  const Slice& slice = GetParam();
  SuiteSet set;
  for (const SuiteSet& s : DevelopmentSuite(SCENELOC_DATA_DIR)) {
    if (s.name == slice.set) set = s;
  }
  if (set.name.empty()) GTEST_SKIP() << slice.set << ": " << SCENELOC_DATA_DIR << " is not present";
  set.tour_limit = slice.tour_limit;
  set.query_limit = slice.query_limit;
  TrainOptions train;
  MatchOptions match;
  ASSERT_TRUE(LoadTrainOptions(SCENELOC_CONFIGS_DIR "/train.yaml", &train).ok());
  ASSERT_TRUE(LoadMatchOptions(SCENELOC_CONFIGS_DIR "/match.yaml", &match).ok());
  SuiteContext context;
  context.cache_dir =
      (fs::path(::testing::TempDir()) / ("sceneloc_real_" + std::to_string(getpid()))).string();
  auto data = LoadSet(set, train.extractor, context);
  ASSERT_TRUE(data.ok()) << data.status().ToString();
  auto ours = RunVariant(*data, train, match, context);
  ASSERT_TRUE(ours.ok()) << ours.status().ToString();
  ASSERT_TRUE(
      RunBaselines(data->queries, data->tour, match.verify_ransac_threshold, &ours->outcomes).ok());
  fs::remove_all(context.cache_dir);
  const double rate = ours->summary.match_rate[2];
  const double baseline = SummariseMethod(ours->outcomes, Method::kBaseline).match_rate[2];
  const double reranked = SummariseMethod(ours->outcomes, Method::kReranked).match_rate[2];
  std::printf("%s (%d locations, %zu queries): ±2 %.3f, baseline %.3f, +ransac %.3f\n", slice.set,
              static_cast<int>(data->tour.size()), data->queries.size(), rate, baseline, reranked);
  EXPECT_GE(rate, slice.floor);
  EXPECT_GT(rate, std::max(baseline, reranked));
}

INSTANTIATE_TEST_SUITE_P(Slices, RealDataTest,
                         ::testing::Values(Slice{"gp_day", 60, 60, 0.88},
                                           Slice{"gp_night_same", 60, 60, 0.75},
                                           Slice{"corridor", 0, 0, 0.60}),
                         [](const auto& info) { return std::string(info.param.set); });

}  // namespace
}  // namespace sceneloc
