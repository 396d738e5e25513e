#include "common/matching/neighbourhood.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

// Three landmarks: g0 with neighbours g1 (p = 1, 10 px to the right) and g2 (p = 0.6,
// 20 px below), values the map's packed neighbours hold exactly (compact.h) in its
// 640-pixel frame. Only the fields eq. 2 reads are filled.
Map HandMap() {
  Map map;
  map.image_width = 640;
  map.image_height = 360;
  map.local_mean.setZero(3, kDescriptorSize);
  Neighbour n1;
  n1.landmark = 1;
  n1.cooccurrence = 1.0f;
  n1.distance_mean = 10;
  n1.distance_var = 100;
  n1.angle_mean = 0;
  n1.angle_var = 0.01f;
  Neighbour n2 = n1;
  n2.landmark = 2;
  n2.cooccurrence = 0.6f;
  n2.distance_mean = 20;
  n2.angle_mean = static_cast<float>(M_PI / 2);
  map.neighbours = {Pack(n1, 640), Pack(n2, 640)};
  map.neighbour_offsets = {0, 2, 2, 2};
  return map;
}

FeatureSet HandFeatures(float f1_y) {
  FeatureSet f;
  f.image_width = 640;
  f.image_height = 360;
  f.keypoints = {{100, 100, 4, 0, 1, 0}, {110, f1_y, 4, 0, 1, 0}, {100, 120, 4, 0, 1, 0}};
  return f;
}

const std::vector<DescriptorMatch> kHandMatches = {{0, 0, 1.0f}, {1, 1, 0.8f}, {2, 2, 0.6f}};

// Query offsets equal to the learnt ones: S_A = 1, so eq. 2 reduces to hand arithmetic.
TEST(NeighbourhoodTest, HandComputedWithAndWithoutCentreTerm) {
  const Map map = HandMap();
  const FeatureSet f = HandFeatures(100);
  // With the centre term: k=1: 0.8 / 2 = 0.4; k=2: (0.8 + 0.6 * 0.6) / 2.6 = 0.44615.
  EXPECT_NEAR(NeighbourhoodSimilarity(f, map, kHandMatches, 0, 0, true, 0), 1.16f / 2.6f, 1e-6);
  // Without: k=1: 0.8 / 1 = 0.8; k=2: 1.16 / 1.6 = 0.725; max 0.8.
  EXPECT_NEAR(NeighbourhoodSimilarity(f, map, kHandMatches, 0, 0, false, 0), 0.8f, 1e-6);
  // Walking only the nearest neighbour: 0.4 with the centre term.
  EXPECT_NEAR(NeighbourhoodSimilarity(f, map, kHandMatches, 0, 0, true, 1), 0.4f, 1e-6);
  // A landmark without neighbours has no neighbourhood support.
  EXPECT_EQ(NeighbourhoodSimilarity(f, map, kHandMatches, 1, 1, true, 0), 0.0f);
}

// A neighbour seen in the wrong direction is discounted by S_A's angle term.
TEST(NeighbourhoodTest, ArrangementSimilarityPenalisesWrongGeometry) {
  const Map map = HandMap();
  const FeatureSet f = HandFeatures(105);  // f1 is 11.18 px away at 26.6 degrees
  // The spreads as the map keeps them (compact.h: within 2.2% of 100 and 0.01).
  const Neighbour n1 = map.NeighbourAt(0);
  const double distance_error = std::hypot(10.0, 5.0) - 10.0;
  const double s_distance = std::exp(-distance_error * distance_error / (2 * n1.distance_var));
  const double s_angle = std::exp(-std::pow(std::atan2(5.0, 10.0), 2) / (2 * n1.angle_var));
  const double k1 = 0.8 * s_distance * s_angle / 2.0;
  const double k2 = (0.8 * s_distance * s_angle + 0.6 * 0.6) / 2.6;
  EXPECT_NEAR(NeighbourhoodSimilarity(f, map, kHandMatches, 0, 0, true, 0), std::max(k1, k2), 1e-6);
}

// The fast path agrees with the reference on a random map and random matches.
TEST(NeighbourhoodTest, FastPathMatchesReference) {
  const Map map = test::MakeRandomMap(12, 300, 5);
  std::mt19937 rng(9);
  FeatureSet f;
  f.image_width = 640;
  f.image_height = 360;
  std::uniform_real_distribution<float> x(0, 640), y(0, 360), s(0.3f, 1.0f);
  for (int i = 0; i < 200; ++i) f.keypoints.push_back({x(rng), y(rng), 4, 0, 1, 0});
  std::vector<DescriptorMatch> matches;
  for (uint32_t g = 0; g < 300; ++g) {
    for (int k = 0; k < 3; ++k) matches.push_back({uint32_t(rng() % 200), g, s(rng)});
  }
  ThreadPool pool(2);
  for (bool centre : {true, false}) {
    const auto fast = NeighbourhoodSimilarities(f, map, matches, centre, 0, &pool);
    ASSERT_EQ(fast.size(), matches.size());
    for (size_t k = 0; k < matches.size(); k += 7) {
      EXPECT_NEAR(fast[k],
                  NeighbourhoodSimilarity(f, map, matches, matches[k].feature, matches[k].landmark,
                                          centre, 0),
                  1e-6);
    }
  }
}

}  // namespace
}  // namespace sceneloc
