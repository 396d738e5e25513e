#include "common/features/extractor.h"

#include <gtest/gtest.h>

#include "common/synthetic/tour_generator.h"

namespace sceneloc {
namespace {

// A tour frame's long side is working_size, whatever the image; small images are enlarged
// at most kMaxUpscale times.
TEST(ExtractorTest, TourTargetSetsTheLongSide) {
  ExtractorOptions o;
  const ExtractionTarget hd = TourTarget(960, 540, o);
  EXPECT_EQ(hd.width, 480);
  EXPECT_EQ(hd.height, 270);
  EXPECT_TRUE((hd.holistic == HolisticGrid{16, 9, 12}));
  const ExtractionTarget fisheye = TourTarget(160, 120, o);
  EXPECT_EQ(fisheye.width, 480);
  EXPECT_EQ(fisheye.height, 360);
  const ExtractionTarget portrait = TourTarget(300, 600, o);
  EXPECT_EQ(portrait.width, 240);
  EXPECT_EQ(portrait.height, 480);
  const ExtractionTarget tiny = TourTarget(40, 30, o);
  EXPECT_EQ(tiny.width, 160);  // 4x, not 12x
  EXPECT_EQ(tiny.height, 120);
}

// A query is brought to the map frame's width with its own aspect, on the map's grid.
TEST(ExtractorTest, QueryTargetMatchesTheMapWidth) {
  const HolisticGrid grid{16, 9, 12};
  const ExtractionTarget night = QueryTarget(640, 360, 480, grid);
  EXPECT_EQ(night.width, 480);
  EXPECT_EQ(night.height, 270);
  EXPECT_TRUE(night.holistic == grid);
  const ExtractionTarget four_three = QueryTarget(1024, 768, 480, grid);
  EXPECT_EQ(four_three.width, 480);
  EXPECT_EQ(four_three.height, 360);
  EXPECT_TRUE(four_three.holistic == grid);  // the map's grid, whatever the aspect
}

// Extraction happens in the target frame: keypoints inside it, the holistic descriptor on
// the target grid, descriptors of unit norm.
TEST(ExtractorTest, ExtractsInTheTargetFrame) {
  TourOptions tour;
  tour.num_locations = 1;
  auto jpegs = RenderTourJpegs(tour, kTrainingPass);
  ASSERT_TRUE(jpegs.ok());
  auto image = DecodeImage((*jpegs)[0], 4096);
  ASSERT_TRUE(image.ok());
  const auto extractor = FeatureExtractor::Create({});
  auto f = extractor->ExtractTour(*image);
  ASSERT_TRUE(f.ok()) << f.status().ToString();
  EXPECT_EQ(f->image_width, 480);
  EXPECT_EQ(f->image_height, 270);
  EXPECT_GT(f->size(), 100);
  for (const Keypoint& k : f->keypoints) {
    EXPECT_GE(k.x, 0);
    EXPECT_LT(k.x, 480);
    EXPECT_GE(k.y, 0);
    EXPECT_LT(k.y, 270);
  }
  EXPECT_NEAR(f->local.row(0).norm(), 1.0f, 1e-4);
  EXPECT_NEAR(f->context.row(0).norm(), 1.0f, 1e-4);
  EXPECT_TRUE((f->holistic_grid == HolisticGrid{16, 9, 12}));
  EXPECT_EQ(f->holistic.size(), 16u * 9 * 12);
}

// Images too small, too large or empty are refused with a clear status, never a crash.
TEST(ExtractorTest, RefusesUnusableImages) {
  const auto extractor = FeatureExtractor::Create({});
  for (const cv::Size size :
       {cv::Size(1, 1), cv::Size(4, 4), cv::Size(4096, 1), cv::Size(15, 40)}) {
    auto f = extractor->ExtractTour(cv::Mat(size, CV_8UC3, cv::Scalar(100, 100, 100)));
    ASSERT_FALSE(f.ok()) << size;
    EXPECT_EQ(f.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(f.status().message().find("too small"), std::string::npos) << f.status().message();
  }
  ExtractorOptions small_cap;
  small_cap.max_image_side = 100;
  auto big = FeatureExtractor::Create(small_cap)->ExtractTour(cv::Mat(200, 200, CV_8UC1));
  EXPECT_EQ(big.status().code(), StatusCode::kResourceExhausted);
  EXPECT_FALSE(extractor->ExtractTour(cv::Mat()).ok());
  // A flat image is a valid frame without keypoints.
  auto flat = extractor->ExtractTour(cv::Mat(120, 160, CV_8UC1, cv::Scalar(50)));
  ASSERT_TRUE(flat.ok());
  EXPECT_EQ(flat->size(), 0);
}

}  // namespace
}  // namespace sceneloc
