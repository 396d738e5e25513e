#include "common/training/calibration.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "common/features/holistic.h"
#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

// Turning a descriptor twice gives it back; once, it is the descriptor of the image turned
// upside down (up to the thumbnail's resampling).
TEST(CalibrationTest, RotationMatchesTheRotatedImage) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> x(0, 480), y(0, 270), v(0, 255);
  cv::Mat image(270, 480, CV_8UC1, cv::Scalar(120));
  for (int i = 0; i < 50; ++i) {
    cv::rectangle(image, {x(rng), y(rng)}, {x(rng), y(rng)}, cv::Scalar(v(rng)), cv::FILLED);
  }
  const HolisticGrid g = GridForFrame(480, 270, HolisticOptions());
  const std::vector<float> h = ComputeHolistic(image, g, 8);
  const std::vector<float> turned = RotateHolistic180(h.data(), g);
  EXPECT_EQ(RotateHolistic180(turned.data(), g), h);
  cv::Mat upside_down;
  cv::rotate(image, upside_down, cv::ROTATE_180);
  const std::vector<float> direct = ComputeHolistic(upside_down, g, 8);
  const float other = HolisticDistance(h.data(), direct.data(), g, 0);
  EXPECT_LT(HolisticDistance(turned.data(), direct.data(), g, 0), 0.1f * other);
}

// Every map with holistic descriptors gets a valid calibration whose off-map level is a
// positive distance with a positive spread; the same map twice gives the same calibration.
TEST(CalibrationTest, CalibratesMapsWithHolisticDescriptors) {
  Map map = test::MakeRandomMap(30, 50, 5);
  map.calibration = Calibration();
  ThreadPool pool(2);
  CalibrateMap(&map, &pool);
  EXPECT_TRUE(map.calibration.valid);
  EXPECT_GT(map.calibration.off_map_distance, 0.0f);
  EXPECT_GT(map.calibration.off_map_spread, 0.0f);
  EXPECT_EQ(map.calibration.samples, 30u);
  const Calibration first = map.calibration;
  CalibrateMap(&map, nullptr, 10);
  EXPECT_EQ(map.calibration.samples, 10u);
  CalibrateMap(&map, nullptr);
  EXPECT_EQ(map.calibration.off_map_distance, first.off_map_distance);
  EXPECT_TRUE(map.Validate().ok());
}

// A map without holistic descriptors stays uncalibrated (the paper's confidence).
TEST(CalibrationTest, NoHolisticNoCalibration) {
  Map map = test::MakeRandomMap(10, 30, 6);
  map.holistic_grid = {};
  map.holistic.clear();
  CalibrateMap(&map, nullptr);
  EXPECT_FALSE(map.calibration.valid);
  EXPECT_TRUE(map.Validate().ok());
}

}  // namespace
}  // namespace sceneloc
