#include "common/training/cooccurrence.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sceneloc {
namespace {

// Two landmarks: g0 in images 0,1,2 and g1 in images 1,2. Offsets g0 -> g1: (10, 0) in
// image 1 and (0, 12) in image 2. So p(g1|g0) = 2/3, p(g0|g1) = 1, distances 10 and 12
// (mean 11, variance 1 -> floored, d_max 1), angles 0 and pi/2 (circular mean pi/4,
// d_max pi/4, variance (pi/4)^2). The frame is 200 pixels on its long side, so a distance
// sd floor of 0.01 is 2 pixels (variance 4). The map keeps them to its packed precision
// (compact.h): distances to 200 / 32768 pixels, co-occurrence to 1/255, angles to pi / 32767
// (mean), pi / 65535 (spread) and pi / 255 (largest deviation).
TEST(CooccurrenceTest, HandComputedStatistics) {
  Map map;
  map.image_names = {"a", "b", "c"};
  map.image_width = 200;
  map.image_height = 100;
  map.local_mean.setZero(2, kDescriptorSize);
  map.observation_offsets = {0, 3, 5};
  const float x[] = {0, 0, 0, 10, 0}, y[] = {0, 0, 0, 0, 12};
  const uint32_t image[] = {0, 1, 2, 1, 2};
  for (int o = 0; o < 5; ++o) map.AddObservation(image[o], x[o], y[o], 4, 0);
  TrainOptions options;
  options.distance_sd_floor = 0.01;
  options.angle_var_floor = 0.01;
  BuildNeighbours(options, &map);
  EXPECT_EQ(map.image_offsets, (std::vector<uint32_t>{0, 1, 3, 5}));
  ASSERT_EQ(map.neighbour_offsets, (std::vector<uint32_t>{0, 1, 2}));
  const Neighbour n = map.NeighbourAt(0);
  EXPECT_EQ(n.landmark, 1u);
  EXPECT_NEAR(n.cooccurrence, 2.0f / 3.0f, 0.5 / 255);
  EXPECT_NEAR(n.distance_mean, 11.0f, 0.004);
  // Spreads within half a step of their log codes (2.2%), angles within pi / 256.
  EXPECT_NEAR(n.distance_var, 4.0f, 4.0f * 0.045f);  // raw variance 1 is below the floor
  EXPECT_NEAR(n.distance_dmax, 1.0f, 0.022f);
  EXPECT_NEAR(n.angle_mean, M_PI / 4, M_PI / 256);
  EXPECT_NEAR(n.angle_dmax, M_PI / 4, M_PI / 510);
  EXPECT_NEAR(n.angle_var, M_PI * M_PI / 16, M_PI * M_PI / 16 * 0.045);
  const Neighbour back = map.NeighbourAt(1);
  EXPECT_EQ(back.landmark, 0u);
  EXPECT_FLOAT_EQ(back.cooccurrence, 1.0f);
  EXPECT_NEAR(back.angle_mean, -3 * M_PI / 4, M_PI / 256);  // the reverse direction
}

// Only the max_neighbours nearest (by mean position) are kept, nearest first.
TEST(CooccurrenceTest, KeepsNearestNeighboursInOrder) {
  Map map;
  map.image_names = {"a"};
  map.local_mean.setZero(4, kDescriptorSize);
  map.observation_offsets = {0, 1, 2, 3, 4};
  for (const float x : {0, 30, 10, 20}) map.AddObservation(0, x, 0, 4, 0);
  TrainOptions options;
  options.max_neighbours = 2;
  BuildNeighbours(options, &map);
  ASSERT_EQ(map.neighbour_offsets[1], 2u);
  EXPECT_EQ(map.neighbours[0].landmark, 2u);
  EXPECT_EQ(map.neighbours[1].landmark, 3u);
}

}  // namespace
}  // namespace sceneloc
