#include "common/training/quality.h"

#include <gtest/gtest.h>

#include "common/matching/descriptor_similarity.h"
#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

Eigen::Matrix<float, 1, kDescriptorSize> Unit(int dim) {
  Eigen::Matrix<float, 1, kDescriptorSize> v;
  v.setZero();
  v[dim] = 1;
  return v;
}

// Eq. 4 on a case small enough to compute by hand. Two landmarks with identical, tight
// models along axis 0 and axis 1. Tour: image 0 has features {e0, e1}, image 1 has
// {e0, e1, e0}. g0 was fused from the e0 features of both images (track 0), g1 from the
// e1 ones (track 1); the third feature of image 1 (an e0) belongs to no landmark.
// Every S_D is 1 for the matching axis and 0 for the other, so p(g|f) = 1 for the one
// landmark each feature resembles: TP(g0) = 2, FP(g0) = 1 (the stray e0), TP(g1) = 2,
// FP(g1) = 0. With prior 1: Q(g0) = 2 / 2 = 1, Q(g1) = 2 / 1 = 2.
TEST(QualityTest, HandComputedEquationFour) {
  Map map;
  map.image_names = {"a", "b"};
  map.image_width = map.image_height = 100;
  map.local_mean.resize(2, kDescriptorSize);
  map.context_mean.resize(2, kDescriptorSize);
  map.local_mean.row(0) = test::DescriptorBytesOf(Unit(0));
  map.local_mean.row(1) = test::DescriptorBytesOf(Unit(1));
  map.context_mean = map.local_mean;
  map.local_dmax = {0.01f, 0.01f};
  map.local_var = {0.001f, 0.001f};
  map.context_dmax.setConstant(2, kNumHistograms, ContextSpreadCode().Encode(0.01f));
  map.context_var.setConstant(2, kNumHistograms, ContextSpreadCode().Encode(0.001f));
  map.Finalize();  // the derived fields S_D reads

  std::vector<FeatureSet> tour(2);
  const int axes[2][3] = {{0, 1, -1}, {0, 1, 0}};
  for (int l = 0; l < 2; ++l) {
    const int n = l == 0 ? 2 : 3;
    tour[l].local.resize(n, kDescriptorSize);
    tour[l].context.resize(n, kDescriptorSize);
    tour[l].keypoints.resize(n);
    for (int i = 0; i < n; ++i) {
      tour[l].local.row(i) = Unit(axes[l][i]);
      tour[l].context.row(i) = Unit(axes[l][i]);
    }
  }
  const std::vector<Track> tracks = {{{0, 0}, {1, 0}}, {{0, 1}, {1, 1}}};
  const auto q = ComputeQuality(map, tracks, WholeTour(tour), 0.3, 1.0, nullptr, nullptr);
  ASSERT_EQ(q.size(), 2u);
  EXPECT_NEAR(q[0], 1.0f, 1e-5);
  EXPECT_NEAR(q[1], 2.0f, 1e-5);
  // The prior is what keeps g1's ratio finite: with prior 0.5, Q(g1) = 2 / 0.5 = 4.
  const auto q_half = ComputeQuality(map, tracks, WholeTour(tour), 0.3, 0.5, nullptr, nullptr);
  EXPECT_NEAR(q_half[0], 2.0f / 1.5f, 1e-5);
  EXPECT_NEAR(q_half[1], 4.0f, 1e-5);
}

}  // namespace
}  // namespace sceneloc
