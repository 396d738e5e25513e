// Training end to end on generated tours: coverage of images that tracking cannot link, the
// quality window, and a tour spooled to disk against one held in memory.
#include "common/training/trainer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>

#include "common/features/extractor.h"
#include "common/map/map_io.h"
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

// A 12-image tour, its features in memory and its JPEG files in a folder.
class WindowTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    tour_ = new std::vector<FeatureSet>(TourFeatures(3, 12, TrainOptions().extractor));
    for (int i = 0; i < 12; ++i) names_.push_back(TourImageName(i));
  }
  static void TearDownTestSuite() {
    delete tour_;
    tour_ = nullptr;
  }
  static TrainResult Train(int window) {
    TrainOptions options;
    options.quality_window = window;
    auto trained = TrainFromFeatures(*tour_, names_, options, 2, nullptr);
    EXPECT_TRUE(trained.ok()) << trained.status().ToString();
    return std::move(trained).value();
  }
  // The map's bytes with the settings and provenance that differ between two runs aligned.
  static std::string Bytes(Map map) {
    map.options.quality_window = 0;
    map.provenance = MapProvenance();
    // Where and when: the tour's walk records its folder and time as the provenance does.
    for (Experience& e : map.experiences) {
      e.name = e.source_dir = e.created_utc = "";
    }
    return SerializeMap(map);
  }
  static std::vector<FeatureSet>* tour_;
  static std::vector<std::string> names_;
};
std::vector<FeatureSet>* WindowTest::tour_ = nullptr;
std::vector<std::string> WindowTest::names_;

// A window as long as the tour or longer is the paper's single pass over the whole tour: the
// same map as a window of 0.
TEST_F(WindowTest, AWindowAsLongAsTheTourIsTheWholeTour) {
  const TrainResult whole = Train(0);
  EXPECT_EQ(whole.summary.quality_windows, 1u);
  for (int window : {12, 1000}) {
    const TrainResult same = Train(window);
    EXPECT_EQ(same.summary.quality_windows, 1u);
    EXPECT_EQ(Bytes(same.map), Bytes(whole.map)) << "window " << window;
  }
}

// A shorter window measures Q chunk by chunk: the same candidates (tracks and coverage do
// not depend on it), their quality measured in ceil(12 / window) chunks, so some Q and the
// selection change; every image keeps its landmarks.
TEST_F(WindowTest, AShorterWindowMeasuresQualityChunkByChunk) {
  const TrainResult whole = Train(0);
  const TrainResult chunked = Train(5);
  EXPECT_EQ(chunked.summary.quality_windows, 3u);
  EXPECT_EQ(chunked.summary.landmarks_before_selection, whole.summary.landmarks_before_selection);
  EXPECT_EQ(chunked.summary.tracks, whole.summary.tracks);
  EXPECT_EQ(chunked.map.options.quality_window, 5);
  EXPECT_NE(Bytes(chunked.map), Bytes(whole.map)) << "the window changed nothing";
  EXPECT_TRUE(chunked.map.Validate().ok());
  EXPECT_GE(chunked.summary.landmarks_per_image_min, 40u);
  // Within 10% of as many landmarks: the windows rank candidates much as the whole tour does.
  EXPECT_NEAR(static_cast<double>(chunked.map.num_landmarks()), whole.map.num_landmarks(),
              0.1 * whole.map.num_landmarks());
}

// sceneloc-train spools a folder's features to disk and trains from the spool: the same map
// as training from the same images' features in memory. Progress reaches the end of every
// stage, in order.
TEST_F(WindowTest, SpooledFolderTrainsAsInMemory) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "window_tour";
  std::filesystem::remove_all(dir);
  TourOptions tour;
  tour.num_locations = 12;
  tour.image_width = 480;
  tour.image_height = 270;
  tour.seed = 3;
  ASSERT_TRUE(WriteTour(tour, dir.string(), kTrainingPass).ok());
  std::vector<std::string> stages;
  std::map<std::string, std::pair<size_t, size_t>> last;
  const ProgressFn progress = [&](const std::string& stage, size_t done, size_t total) {
    if (stages.empty() || stages.back() != stage) stages.push_back(stage);
    last[stage] = {done, total};
  };
  TrainOptions options;
  options.quality_window = 5;
  auto spooled = TrainFromFolder(dir.string(), options, 2, progress, ::testing::TempDir());
  ASSERT_TRUE(spooled.ok()) << spooled.status().ToString();
  EXPECT_GT(spooled->summary.spool_bytes, 0u);
  EXPECT_EQ(Bytes(spooled->map), Bytes(Train(5).map));
  EXPECT_EQ(stages,
            (std::vector<std::string>{"extract", "link", "quality", "fuse", "look-alikes"}));
  for (const auto& [stage, counts] : last) EXPECT_EQ(counts.first, counts.second) << stage;
}

}  // namespace
}  // namespace sceneloc
