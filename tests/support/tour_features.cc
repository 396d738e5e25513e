#include "tests/support/tour_features.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

namespace sceneloc::test {

TourOptions SmallTour(int locations, uint32_t seed) {
  TourOptions tour;
  tour.num_locations = locations;
  tour.image_width = 320;
  tour.image_height = 180;
  tour.seed = seed;
  return tour;
}

std::vector<FeatureSet> ExtractTourPass(const TourOptions& tour, int pass,
                                        const ExtractorOptions& options,
                                        const ExtractionTarget* map_frame) {
  const StatusOr<std::vector<std::string>> jpegs = RenderTourJpegs(tour, pass);
  EXPECT_TRUE(jpegs.ok()) << jpegs.status().ToString();
  if (!jpegs.ok()) return {};
  const auto extractor = FeatureExtractor::Create(options);
  std::vector<FeatureSet> sets;
  for (const std::string& jpeg : *jpegs) {
    const StatusOr<cv::Mat> image = DecodeImage(jpeg, options.max_image_side);
    EXPECT_TRUE(image.ok()) << image.status().ToString();
    if (!image.ok()) return {};
    const ExtractionTarget target =
        map_frame == nullptr
            ? TourTarget(image->cols, image->rows, options)
            : QueryTarget(image->cols, image->rows, map_frame->width, map_frame->holistic);
    StatusOr<FeatureSet> features = extractor->Extract(*image, target);
    EXPECT_TRUE(features.ok()) << features.status().ToString();
    if (!features.ok()) return {};
    sets.push_back(std::move(features).value());
  }
  return sets;
}

ExtractionTarget MapFrameOf(const std::vector<FeatureSet>& tour_features) {
  ExtractionTarget frame;
  if (tour_features.empty()) return frame;
  frame.width = tour_features.front().image_width;
  frame.height = tour_features.front().image_height;
  frame.holistic = tour_features.front().holistic_grid;
  return frame;
}

void ExpectFeatureSetsEqual(const FeatureSet& a, const FeatureSet& b) {
  EXPECT_EQ(a.image_width, b.image_width);
  EXPECT_EQ(a.image_height, b.image_height);
  ASSERT_EQ(a.keypoints.size(), b.keypoints.size());
  EXPECT_EQ(
      std::memcmp(a.keypoints.data(), b.keypoints.data(), a.keypoints.size() * sizeof(Keypoint)),
      0);
  EXPECT_TRUE(a.local == b.local);
  EXPECT_TRUE(a.context == b.context);
  EXPECT_EQ(a.holistic_grid, b.holistic_grid);
  EXPECT_EQ(a.holistic, b.holistic);
}

}  // namespace sceneloc::test
