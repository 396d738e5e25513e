// The map's look-alikes (common/training/lookalikes.h), measured at training on generated
// tours (real JPEG bytes, a real trained map): a street that repeats every block is full of
// them, the plain street has none; and how they are stored and grouped.
#include "common/training/lookalikes.h"

#include <gtest/gtest.h>

#include <cstdlib>

#include "common/training/trainer.h"
#include "tests/support/tour_features.h"

namespace sceneloc {
namespace {

constexpr int kLocations = 40;
constexpr int kBlock = 10;  // locations a 40 m block spans at 4 m a location

TrainResult TrainStreet(int repeat_blocks) {
  TourOptions tour = test::SmallTour(kLocations, 3);
  tour.step = 0.4;  // 4 m a location
  tour.repeat_blocks = repeat_blocks;
  TrainOptions options;
  const std::vector<FeatureSet> features =
      test::ExtractTourPass(tour, kTrainingPass, options.extractor);
  std::vector<std::string> names;
  for (int i = 0; i < kLocations; ++i) names.push_back(TourImageName(i));
  auto trained = TrainFromFeatures(features, names, options, 2, nullptr);
  EXPECT_TRUE(trained.ok()) << trained.status().ToString();
  return trained.ok() ? std::move(trained).value() : TrainResult();
}

// Every block the same: most places verify against a place a whole number of blocks away, as
// strongly as against themselves, and the map stores them (both ways, within the cap).
TEST(LookAlikesTest, ARepeatingStreetIsFullOfThem) {
  const TrainResult trained = TrainStreet(1);
  const Map& map = trained.map;
  ASSERT_EQ(trained.summary.lookalikes.size(), static_cast<size_t>(kLocations));
  ASSERT_TRUE(map.has_lookalikes());
  EXPECT_TRUE(map.Validate().ok());
  int repeats = 0;
  for (int t = 0; t < kLocations; ++t) {
    const LookAlike& a = trained.summary.lookalikes[static_cast<size_t>(t)];
    if (a.rival < 0 || a.excess < kLookAlikeInliers) continue;
    const int offset = std::abs(a.rival - t) % kBlock;
    repeats += (offset <= 2 || offset >= kBlock - 2) && a.excess > 0.5f * a.own;
  }
  EXPECT_GE(repeats, kLocations * 3 / 4);
  size_t stored = 0;
  for (int t = 0; t < kLocations; ++t) {
    const uint32_t begin = map.lookalike_offsets[t], end = map.lookalike_offsets[t + 1];
    EXPECT_LE(end - begin, static_cast<uint32_t>(kMaxLookAlikes));
    stored += end - begin > 0;
  }
  EXPECT_GE(stored, static_cast<size_t>(kLocations * 3 / 4));
  EXPECT_FALSE(LookAlikeStretches(trained.summary.lookalikes, kLookAlikeInliers).empty());
}

// The plain street: no place verifies against another more than kHeldOutFrames away, and
// the map stores that it measured none.
TEST(LookAlikesTest, APlainStreetHasNone) {
  const TrainResult trained = TrainStreet(0);
  const Map& map = trained.map;
  ASSERT_TRUE(map.has_lookalikes());
  EXPECT_LE(map.lookalike_location.size(), static_cast<size_t>(kLocations / 10));
}

// Storing: a rival at the threshold makes both places look-alikes at the ratio of the
// evidence; one below it, a frame without own evidence or without a rival make none; a
// place keeps its kMaxLookAlikes strongest.
TEST(LookAlikesTest, StoredBothWaysAboveTheThreshold) {
  Map map;
  map.image_names.resize(30);
  std::vector<LookAlike> a(30);
  a[2] = {20, 8.0f, 16.0f};   // at the threshold, half the own evidence
  a[3] = {21, 7.9f, 16.0f};   // below
  a[4] = {22, 50.0f, 0.0f};   // no own evidence
  a[5] = {25, 40.0f, 20.0f};  // more than its own: ratio 1
  for (int t = 10; t < 10 + kMaxLookAlikes + 2; ++t)
    a[static_cast<size_t>(t)] = {0, 10.0f + t, 100.0f};
  StoreLookAlikes(a, kLookAlikeInliers, &map);
  ASSERT_EQ(map.lookalike_offsets.size(), 31u);
  const auto list = [&](int l) {
    std::vector<std::pair<uint32_t, float>> out;
    for (uint32_t k = map.lookalike_offsets[l]; k < map.lookalike_offsets[l + 1]; ++k) {
      out.emplace_back(map.lookalike_location[k], map.lookalike_ratio[k]);
    }
    return out;
  };
  EXPECT_EQ(list(2), (std::vector<std::pair<uint32_t, float>>{{20, 0.5f}}));
  EXPECT_EQ(list(20), (std::vector<std::pair<uint32_t, float>>{{2, 0.5f}}));
  EXPECT_TRUE(list(3).empty());
  EXPECT_TRUE(list(21).empty());
  EXPECT_TRUE(list(4).empty());
  EXPECT_EQ(list(25), (std::vector<std::pair<uint32_t, float>>{{5, 1.0f}}));
  // Location 0 is the rival of 10 frames: it keeps the strongest, in tour order.
  const auto zero = list(0);
  ASSERT_EQ(zero.size(), static_cast<size_t>(kMaxLookAlikes));
  EXPECT_EQ(zero.front().first, 12u);
  EXPECT_EQ(zero.back().first, static_cast<uint32_t>(11 + kMaxLookAlikes));
}

// Three twins, each frame naming one rival: every twin is linked to both others, a
// look-alike's look-alike at the product of the ratios; one within kHeldOutFrames is not.
TEST(LookAlikesTest, ALookAlikesLookAlikeCounts) {
  Map map;
  map.image_names.resize(100);
  std::vector<LookAlike> a(100);
  a[0] = {40, 20.0f, 20.0f};   // ratio 1
  a[40] = {80, 18.0f, 20.0f};  // ratio 0.9
  a[10] = {50, 10.0f, 20.0f};  // ratio 0.5; 50's other look-alike, 15, is near 10
  a[15] = {50, 10.0f, 20.0f};
  StoreLookAlikes(a, kLookAlikeInliers, &map);
  const auto list = [&](int l) {
    std::vector<std::pair<uint32_t, float>> out;
    for (uint32_t k = map.lookalike_offsets[l]; k < map.lookalike_offsets[l + 1]; ++k) {
      out.emplace_back(map.lookalike_location[k], map.lookalike_ratio[k]);
    }
    return out;
  };
  using List = std::vector<std::pair<uint32_t, float>>;
  EXPECT_EQ(list(0), (List{{40, 1.0f}, {80, 0.9f}}));
  EXPECT_EQ(list(40), (List{{0, 1.0f}, {80, 0.9f}}));
  EXPECT_EQ(list(80), (List{{0, 0.9f}, {40, 0.9f}}));
  EXPECT_EQ(list(10), (List{{50, 0.5f}}));
  EXPECT_EQ(list(15), (List{{50, 0.5f}}));
  EXPECT_EQ(list(50), (List{{10, 0.5f}, {15, 0.5f}}));
}

// Grouping: frames whose rivals advance with them (either way) make one stretch; a rival
// elsewhere starts another; the strongest stretch comes first.
TEST(LookAlikesTest, StretchesFollowTheRivals) {
  std::vector<LookAlike> a(60);
  for (int t = 10; t <= 14; ++t) a[static_cast<size_t>(t)] = {40 + (t - 10), 20.0f, 30.0f};
  for (int t = 20; t <= 22; ++t) a[static_cast<size_t>(t)] = {55 - (t - 20), 50.0f, 60.0f};
  a[23] = {5, 30.0f, 40.0f};  // elsewhere
  a[30] = {50, 4.0f, 40.0f};  // below the threshold
  const std::vector<LookAlikeStretch> s = LookAlikeStretches(a, kLookAlikeInliers);
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].first, 20);
  EXPECT_EQ(s[0].last, 22);
  EXPECT_EQ(s[0].rival_first, 53);
  EXPECT_EQ(s[0].rival_last, 55);
  EXPECT_EQ(s[0].excess, 50.0f);
  EXPECT_EQ(s[1].first, 23);
  EXPECT_EQ(s[2].first, 10);
  EXPECT_EQ(s[2].last, 14);
  EXPECT_EQ(s[2].rival_first, 40);
  EXPECT_EQ(s[2].rival_last, 44);
}

}  // namespace
}  // namespace sceneloc
