#include "common/matching/similarity.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sceneloc {
namespace {

// Eq. 1: 1 within d_max, and the Gaussian tail beyond, against hand-computed values.
TEST(SimilarityTest, MatchesEquationOne) {
  EXPECT_FLOAT_EQ(SimilarityFromSquared(0.0f, 0.2f, 0.01f), 1.0f);
  EXPECT_FLOAT_EQ(SimilarityFromSquared(0.04f, 0.2f, 0.01f), 1.0f);  // d == d_max
  // d = 0.3, d_max = 0.2, sigma^2 = 0.01: exp(-(0.09 - 0.04) / 0.02) = exp(-2.5)
  EXPECT_NEAR(SimilarityFromSquared(0.09f, 0.2f, 0.01f), 0.0820850f, 1e-6);
  // The paper's kappa form: kappa * exp(-d^2 / 2 sigma^2), kappa = exp(d_max^2 / 2 sigma^2).
  const double kappa = std::exp(0.04 / 0.02);
  EXPECT_NEAR(SimilarityFromSquared(0.09f, 0.2f, 0.01f), kappa * std::exp(-0.09 / 0.02), 1e-6);
}

// The distance limit is exactly where the similarity crosses s_min.
TEST(SimilarityTest, DistanceLimitIsTheSminCrossing) {
  const float limit = SquaredDistanceLimit(0.2f, 0.01f, 0.3f);
  EXPECT_NEAR(SimilarityFromSquared(limit, 0.2f, 0.01f), 0.3f, 1e-5);
  EXPECT_GT(SimilarityFromSquared(limit * 0.99f, 0.2f, 0.01f), 0.3f);
  EXPECT_LT(SimilarityFromSquared(limit * 1.01f, 0.2f, 0.01f), 0.3f);
}

// Angle differences wrap into [-pi, pi].
TEST(SimilarityTest, WrapAngle) {
  EXPECT_NEAR(WrapAngle(0.1f), 0.1f, 1e-6);
  EXPECT_NEAR(WrapAngle(2 * 3.14159265f + 0.1f), 0.1f, 1e-5);
  EXPECT_NEAR(WrapAngle(3.0f - (-3.0f)), 6.0f - 2 * 3.14159265f, 1e-5);
  EXPECT_NEAR(WrapAngle(-3.5f), -3.5f + 2 * 3.14159265f, 1e-5);
}

}  // namespace
}  // namespace sceneloc
