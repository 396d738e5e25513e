#include "common/training/selection.h"

#include <gtest/gtest.h>

namespace sceneloc {
namespace {

// The paper's iterative algorithm on a hand-made case: 3 images, eta = 2.
//   g0 (Q 0.9) images 0,1   g1 (Q 0.8) image 0    g2 (Q 0.7) images 1,2
//   g3 (Q 0.6) image 2      g4 (Q 0.5) image 2    g5 (Q 0.005) image 2 (below q_min)
// Round 1: I_min = image 0 (0 assigned): take g0, g1 -> counts 2,1,0.
// Round 2: I_min = image 2: take g2, g3 -> counts 2,2,2. Stop. g4, g5 never selected.
TEST(SelectionTest, HandComputedIterations) {
  const std::vector<std::vector<uint32_t>> images = {{0, 1}, {0}, {1, 2}, {2}, {2}, {2}};
  const std::vector<float> q = {0.9f, 0.8f, 0.7f, 0.6f, 0.5f, 0.005f};
  EXPECT_EQ(SelectLandmarks(images, q, 3, 2, 0.01), (std::vector<uint32_t>{0, 1, 2, 3}));
}

// q_min is a hard floor even when an image stays below eta; the loop still ends.
TEST(SelectionTest, QminFloorAndExhaustedImages) {
  const std::vector<std::vector<uint32_t>> images = {{0}, {1}, {1}};
  const std::vector<float> q = {0.5f, 0.009f, 0.2f};
  EXPECT_EQ(SelectLandmarks(images, q, 2, 5, 0.01), (std::vector<uint32_t>{0, 2}));
}

// eta = 0 keeps every landmark above q_min.
TEST(SelectionTest, EtaZeroKeepsAllAboveQmin) {
  const std::vector<std::vector<uint32_t>> images = {{0}, {0}, {1}};
  const std::vector<float> q = {0.5f, 0.001f, 0.02f};
  EXPECT_EQ(SelectLandmarks(images, q, 2, 0, 0.01), (std::vector<uint32_t>{0, 2}));
}

}  // namespace
}  // namespace sceneloc
