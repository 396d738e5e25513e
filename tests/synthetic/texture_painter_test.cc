// The scene's drawing primitives (common/synthetic/texture_painter.h): random streams that
// depend on their arguments alone, gradients, layers and pillars drawn deterministically.
#include "common/synthetic/texture_painter.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

namespace sceneloc::synthetic_internal {
namespace {

// The first few draws of a stream, to compare streams by.
std::vector<int> FirstDraws(cv::RNG rng) {
  std::vector<int> draws;
  for (int i = 0; i < 4; ++i) draws.push_back(rng.uniform(0, 1 << 30));
  return draws;
}

bool SameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// A painter over the whole of `canvas` at reference scale.
Painter WholeCanvas(cv::Mat* canvas) {
  return Painter{canvas, 1.0, 0, static_cast<double>(canvas->cols),
                 static_cast<double>(canvas->rows)};
}

// A stream is a function of (seed, stream, tile, layer) alone: the same arguments give
// the same draws, and changing any one of them gives other draws.
TEST(TexturePainterTest, RngForDependsOnEveryArgument) {
  const std::vector<int> base = FirstDraws(RngFor(7, 1, 3, 0));
  EXPECT_EQ(FirstDraws(RngFor(7, 1, 3, 0)), base);
  EXPECT_NE(FirstDraws(RngFor(8, 1, 3, 0)), base);
  EXPECT_NE(FirstDraws(RngFor(7, 2, 3, 0)), base);
  EXPECT_NE(FirstDraws(RngFor(7, 1, 4, 0)), base);
  EXPECT_NE(FirstDraws(RngFor(7, 1, 3, 1)), base);
  EXPECT_NE(FirstDraws(RngFor(7, 1, -3, 0)), base);
}

// Reference pixels scale to canvas pixels: lengths round and never vanish, positions are
// offset by the region's origin, and counts follow the region's height.
TEST(TexturePainterTest, PainterScalesReferencePixels) {
  cv::Mat canvas(10, 10, CV_8UC3);
  const Painter p{&canvas, 0.5, 100, 512, 480};
  EXPECT_EQ(p.Off(7), 4);  // 3.5 rounds away from zero
  EXPECT_EQ(p.Len(0.4), 1);
  EXPECT_EQ(p.At(10, 20), cv::Point(105, 10));
  EXPECT_EQ(p.Count(80), 40);
}

// A horizontal gradient runs from the first colour in the first column to the second in
// the last, rising steadily; a vertical one does the same down the rows.
TEST(TexturePainterTest, FillGradientRunsBetweenTheColours) {
  cv::Mat canvas(4, 6, CV_8UC3, cv::Scalar::all(0));
  FillGradient(cv::Rect(0, 0, 6, 4), cv::Scalar::all(0), cv::Scalar::all(250), false, &canvas);
  for (int c = 0; c < 6; ++c) {
    EXPECT_EQ(canvas.at<cv::Vec3b>(2, c)[1], 50 * c) << "column " << c;
  }
  FillGradient(cv::Rect(0, 0, 6, 4), cv::Scalar(30, 60, 90), cv::Scalar(30, 60, 90), true, &canvas);
  EXPECT_EQ(canvas.at<cv::Vec3b>(3, 5), cv::Vec3b(30, 60, 90));
}

// A gradient reaching outside the canvas fills only the part inside, with the colours it
// has there (the ramp is the whole rectangle's, not the clipped part's).
TEST(TexturePainterTest, FillGradientIsClippedToTheCanvas) {
  cv::Mat canvas(2, 4, CV_8UC3, cv::Scalar::all(7));
  FillGradient(cv::Rect(-2, 0, 6, 2), cv::Scalar::all(0), cv::Scalar::all(250), false, &canvas);
  EXPECT_EQ(canvas.at<cv::Vec3b>(0, 0)[0], 100);  // column 2 of the ramp
  EXPECT_EQ(canvas.at<cv::Vec3b>(0, 3)[0], 250);
  FillGradient(cv::Rect(10, 10, 3, 3), cv::Scalar::all(0), cv::Scalar::all(0), false, &canvas);
  EXPECT_EQ(canvas.at<cv::Vec3b>(1, 3)[0], 250);  // a rectangle outside draws nothing
}

// Each facade layer draws something, the same from the same stream, and the layers
// differ from each other.
TEST(TexturePainterTest, FacadeLayersAreDeterministicAndDistinct) {
  std::vector<cv::Mat> layers;
  for (int layer = 0; layer < kFacadeLayers; ++layer) {
    cv::Mat a(240, 320, CV_8UC3, cv::Scalar::all(128)), b = a.clone();
    cv::RNG rng_a = RngFor(1, 1, 0, layer), rng_b = RngFor(1, 1, 0, layer);
    DrawFacadeLayer(layer, rng_a, WholeCanvas(&a));
    DrawFacadeLayer(layer, rng_b, WholeCanvas(&b));
    EXPECT_TRUE(SameImage(a, b)) << "layer " << layer;
    EXPECT_GT(cv::norm(a, cv::Mat(a.size(), a.type(), cv::Scalar::all(128)), cv::NORM_L1), 0)
        << "layer " << layer << " drew nothing";
    for (const cv::Mat& earlier : layers) EXPECT_FALSE(SameImage(a, earlier));
    layers.push_back(a);
  }
}

// Pillars are full-height strips: every column they cover is opaque in the mask from top
// to bottom, and the canvas is untouched wherever the mask is clear.
TEST(TexturePainterTest, PillarsPaintExactlyWhatTheirMaskCovers) {
  int seeds_with_pillars = 0;
  for (uint32_t seed = 1; seed <= 6; ++seed) {
    cv::Mat canvas(200, 300, CV_8UC3, cv::Scalar(1, 2, 3));
    cv::Mat mask = cv::Mat::zeros(200, 300, CV_8UC1);
    cv::RNG rng = RngFor(seed, 2, 0, 0);
    DrawPillars(rng, WholeCanvas(&canvas), &mask);
    if (cv::countNonZero(mask) == 0) continue;
    ++seeds_with_pillars;
    cv::Mat column_sums;
    cv::reduce(mask / 255, column_sums, 0, cv::REDUCE_SUM, CV_32S);
    for (int c = 0; c < mask.cols; ++c) {
      const int opaque = column_sums.at<int>(0, c);
      EXPECT_TRUE(opaque == 0 || opaque == mask.rows) << "seed " << seed << ", column " << c;
    }
    cv::Mat untouched;
    cv::inRange(canvas, cv::Scalar(1, 2, 3), cv::Scalar(1, 2, 3), untouched);
    EXPECT_EQ(cv::countNonZero(untouched | mask), canvas.total()) << "seed " << seed;
  }
  EXPECT_GT(seeds_with_pillars, 0);
}

// Grain changes the pixels but not the brightness: its mean is near zero.
TEST(TexturePainterTest, GrainKeepsTheMeanBrightness) {
  cv::Mat image(100, 100, CV_8UC3, cv::Scalar::all(100));
  const cv::Mat before = image.clone();
  cv::RNG rng(5);
  AddGrain(rng, &image);
  EXPECT_FALSE(SameImage(image, before));
  EXPECT_NEAR(cv::mean(image)[0], 100.0, 1.0);
}

}  // namespace
}  // namespace sceneloc::synthetic_internal
