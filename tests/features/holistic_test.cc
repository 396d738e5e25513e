#include "common/features/holistic.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <random>

namespace sceneloc {
namespace {

// A textured test frame: random rectangles and lines, seeded.
cv::Mat Scene(int width, int height, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> x(0, width), y(0, height), v(0, 255);
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(128));
  for (int i = 0; i < 60; ++i) {
    cv::rectangle(image, {x(rng), y(rng)}, {x(rng), y(rng)}, cv::Scalar(v(rng)), cv::FILLED);
    cv::line(image, {x(rng), y(rng)}, {x(rng), y(rng)}, cv::Scalar(v(rng)), 3);
  }
  return image;
}

HolisticGrid Grid() { return GridForFrame(480, 270, HolisticOptions()); }

// The grid follows the frame's aspect ratio: 16 cells wide, 9 high at 16:9, 12 at 4:3.
TEST(HolisticTest, GridFollowsAspect) {
  EXPECT_TRUE((GridForFrame(480, 270, {}) == HolisticGrid{16, 9, 12}));
  EXPECT_TRUE((GridForFrame(160, 120, {}) == HolisticGrid{16, 12, 12}));
  EXPECT_TRUE(GridForFrame(480, 270, HolisticOptions{0, 8, 12}).empty());
  EXPECT_EQ(GridForFrame(4096, 16, {}).rows, 2);  // never fewer than 2 rows
}

// Values lie in [0, 1]; a flat image gives zeros, not NaNs.
TEST(HolisticTest, ValuesBoundedAndFlatImageIsZero) {
  const std::vector<float> h = ComputeHolistic(Scene(480, 270, 1), Grid(), 8);
  ASSERT_EQ(h.size(), static_cast<size_t>(Grid().size()));
  for (float v : h) {
    EXPECT_GE(v, 0.0f);
    EXPECT_LE(v, 1.0f);
  }
  EXPECT_GT(*std::max_element(h.begin(), h.end()), 0.1f);
  for (float v : ComputeHolistic(cv::Mat(270, 480, CV_8UC1, cv::Scalar(77)), Grid(), 8)) {
    EXPECT_EQ(v, 0.0f);
  }
}

// The same scene at half the light, or another resolution, is (nearly) the same
// descriptor; another scene is far.
TEST(HolisticTest, InvariantToBrightnessAndResolution) {
  const cv::Mat scene = Scene(480, 270, 2);
  cv::Mat dim, small;
  scene.convertTo(dim, CV_8UC1, 0.5);
  cv::resize(scene, small, cv::Size(320, 180), 0, 0, cv::INTER_AREA);
  const HolisticGrid g = Grid();
  const auto a = ComputeHolistic(scene, g, 8), b = ComputeHolistic(dim, g, 8);
  const auto c = ComputeHolistic(small, g, 8), other = ComputeHolistic(Scene(480, 270, 3), g, 8);
  const float far = HolisticDistance(a.data(), other.data(), g, 0);
  EXPECT_EQ(HolisticDistance(a.data(), a.data(), g, 2), 0.0f);
  EXPECT_LT(HolisticDistance(a.data(), b.data(), g, 0), 0.1f * far);
  EXPECT_LT(HolisticDistance(a.data(), c.data(), g, 0), 0.3f * far);
}

// A view shifted sideways by one cell matches once the comparison may shift one cell.
TEST(HolisticTest, ShiftToleranceFindsLateralOffset) {
  const cv::Mat wide = Scene(480 + 30, 270, 4);
  const cv::Mat left = wide(cv::Rect(0, 0, 480, 270)), right = wide(cv::Rect(30, 0, 480, 270));
  const HolisticGrid g = Grid();
  const auto a = ComputeHolistic(left, g, 8), b = ComputeHolistic(right, g, 8);
  EXPECT_LT(HolisticDistance(a.data(), b.data(), g, 1),
            0.5f * HolisticDistance(a.data(), b.data(), g, 0));
  // Symmetric in its arguments.
  EXPECT_FLOAT_EQ(HolisticDistance(a.data(), b.data(), g, 2),
                  HolisticDistance(b.data(), a.data(), g, 2));
}

// HolisticDistance equals a brute-force minimum over shifts of the mean squared cell
// difference.
TEST(HolisticTest, DistanceMatchesBruteForce) {
  const HolisticGrid g{5, 3, 4};
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0, 1);
  std::vector<float> a(g.size()), b(g.size());
  for (auto& v : a) v = u(rng);
  for (auto& v : b) v = u(rng);
  for (int max_shift = 0; max_shift <= 3; ++max_shift) {
    double best = 1e9;
    for (int s = -max_shift; s <= max_shift; ++s) {
      double sum = 0;
      int cells = 0;
      for (int r = 0; r < g.rows; ++r) {
        for (int c = 0; c < g.cols; ++c) {
          if (c - s < 0 || c - s >= g.cols) continue;
          ++cells;
          for (int k = 0; k < g.bins; ++k) {
            const double d =
                a[(r * g.cols + c) * g.bins + k] - b[(r * g.cols + c - s) * g.bins + k];
            sum += d * d;
          }
        }
      }
      best = std::min(best, sum / cells);
    }
    EXPECT_NEAR(HolisticDistance(a.data(), b.data(), g, max_shift), best, 1e-5) << max_shift;
  }
}

}  // namespace
}  // namespace sceneloc
