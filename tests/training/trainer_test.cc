// Training end to end on generated tours: coverage of images that tracking cannot link.
#include "common/training/trainer.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "common/features/extractor.h"
#include "common/synthetic/tour_generator.h"

namespace sceneloc {
namespace {

std::vector<FeatureSet> TourFeatures(uint32_t seed, int locations, const ExtractorOptions& o) {
  TourOptions tour;
  tour.num_locations = locations;
  tour.image_width = 480;
  tour.image_height = 270;
  tour.seed = seed;
  auto jpegs = RenderTourJpegs(tour, kTrainingPass);
  EXPECT_TRUE(jpegs.ok());
  const auto extractor = FeatureExtractor::Create(o);
  std::vector<FeatureSet> out;
  for (const std::string& jpeg : *jpegs) {
    auto image = DecodeImage(jpeg, 8192);
    EXPECT_TRUE(image.ok());
    auto f = extractor->Extract(*image, TourTarget(image->cols, image->rows, o));
    EXPECT_TRUE(f.ok());
    out.push_back(std::move(f).value());
  }
  return out;
}

// A tour whose image 5 comes from another scene: tracking links it to its neighbours only
// by chance (a few dozen candidates against 150-230 for the others, as at a sharp turn or
// on a blank wall). Coverage tops every image up to min_landmarks_per_image from its
// untracked features, so no location is left thin or unanswerable.
class CoverageTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const TrainOptions options;
    auto route = TourFeatures(1, 10, options.extractor);
    route[5] = TourFeatures(7, 3, options.extractor)[2];
    tour_ = new std::vector<FeatureSet>(std::move(route));
    for (int i = 0; i < 10; ++i) names_.push_back("Image" + std::to_string(i) + ".jpg");
  }
  static void TearDownTestSuite() {
    delete tour_;
    tour_ = nullptr;
  }
  static size_t LandmarksOf(const Map& map, int image) {
    return map.image_offsets[image + 1] - map.image_offsets[image];
  }
  static std::vector<FeatureSet>* tour_;
  static std::vector<std::string> names_;
};
std::vector<FeatureSet>* CoverageTest::tour_ = nullptr;
std::vector<std::string> CoverageTest::names_;

TEST_F(CoverageTest, TopsUpTheImageTrackingCouldNotLink) {
  TrainOptions without = TrainOptions();
  without.min_landmarks_per_image = 0;
  auto bare = TrainFromFeatures(*tour_, names_, without, 2, nullptr);
  ASSERT_TRUE(bare.ok()) << bare.status().ToString();
  EXPECT_EQ(bare->summary.coverage_landmarks, 0u);
  const size_t thin = LandmarksOf(bare->map, 5);
  ASSERT_LT(thin, 40u) << "the foreign image was linked like any other: the test proves nothing";
  EXPECT_EQ(bare->summary.landmarks_per_image_min, thin);

  const TrainOptions with;  // min_landmarks_per_image 40
  auto covered = TrainFromFeatures(*tour_, names_, with, 2, nullptr);
  ASSERT_TRUE(covered.ok()) << covered.status().ToString();
  const TrainSummary& s = covered->summary;
  EXPECT_GT(s.coverage_landmarks, 0u);
  EXPECT_GE(LandmarksOf(covered->map, 5), 40u);
  EXPECT_GE(s.landmarks_per_image_min, 40u);
  EXPECT_TRUE(s.images_without_landmarks.empty());
}

}  // namespace
}  // namespace sceneloc
