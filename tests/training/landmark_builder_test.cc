#include "common/training/landmark_builder.h"

#include <gtest/gtest.h>

namespace sceneloc {
namespace {

// Fusion of a 2-feature track by hand: local a1 = e0, a2 = e1 (unit axes) -> mean
// (0.5, 0.5, 0...), each 1/sqrt(2) from it: d_max = 0.7071, sigma^2 = 0.5. Context: both
// features equal, so every histogram has d_max = 0 and sigma^2 at the floor. The map holds
// the means as bytes (compact.h) and measures the spreads from what it holds: within a
// byte's step (1/255) of those figures.
TEST(LandmarkBuilderTest, FusesMeanDmaxAndFlooredVariance) {
  std::vector<FeatureSet> tour(2);
  for (int l = 0; l < 2; ++l) {
    tour[l].keypoints = {{10.0f + 4 * l, 20, 4, 0, 1, 0}};
    tour[l].local.setZero(1, kDescriptorSize);
    tour[l].local(0, l) = 1;
    tour[l].context.setConstant(1, kDescriptorSize, 1.0f / std::sqrt(128.0f));
  }
  TrainOptions options;
  Map map;
  FuseLandmarks({{{0, 0}, {1, 0}}}, WholeTour(tour), options, &map);
  ASSERT_EQ(map.num_landmarks(), 1);
  EXPECT_EQ(map.local_mean(0, 0), UnitByte(0.5f));
  EXPECT_EQ(map.local_mean(0, 1), UnitByte(0.5f));
  EXPECT_EQ(map.local_mean(0, 2), 0);
  EXPECT_NEAR(map.local_dmax[0], std::sqrt(0.5f), 0.5f / 255);
  EXPECT_NEAR(map.local_var[0], 0.5f, 0.5f / 255);
  for (int h = 0; h < kNumHistograms; ++h) {
    EXPECT_NEAR(map.ContextDmax(0, h), 0.0f, std::sqrt(8.0f) * 0.5f / 255);
    // The floor, within half a step of its code.
    EXPECT_NEAR(map.ContextVar(0, h), float(options.context_var_floor),
                options.context_var_floor * (std::sqrt(ContextSpreadCode().step()) - 1));
  }
  EXPECT_FLOAT_EQ(map.MeanPosition(0)[0], 12.0f);
  EXPECT_FLOAT_EQ(map.MeanPosition(0)[1], 20.0f);
  EXPECT_EQ(map.observation_offsets, (std::vector<uint32_t>{0, 2}));
  EXPECT_EQ(map.observation_image, (std::vector<uint32_t>{0, 1}));
}

}  // namespace
}  // namespace sceneloc
