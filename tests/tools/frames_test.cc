// The working frame, end to end on a generated tour: a map trained at one resolution
// localises queries from cameras of other resolutions, feature sets extracted in another
// frame, a darker pass and a smaller camera, from real JPEG bytes.
#include <gtest/gtest.h>

#include <filesystem>

#include "common/features/extractor.h"
#include "common/map/map_io.h"
#include "common/matching/localiser.h"
#include "common/synthetic/tour_generator.h"
#include "common/training/trainer.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

constexpr int kLocations = 20;

// The map every test uses: trained once per ctest run by the tools/TrainFramesMap fixture
// (this binary with --train-map), from the default 640x360 generated tour.
const std::string kMapPath = SCENELOC_TEST_DATA_DIR "/frames.scnl";

Status TrainFramesMap() {
  const fs::path dir =
      fs::path(::testing::TempDir()) / ("sceneloc_frames_" + std::to_string(::getpid()));
  TourOptions tour;
  tour.num_locations = kLocations;
  SCENELOC_RETURN_IF_ERROR(WriteTour(tour, dir.string(), kTrainingPass));
  auto trained = TrainFromFolder(dir.string(), TrainOptions(), 2, nullptr);
  fs::remove_all(dir);
  if (!trained.ok()) return trained.status();
  fs::create_directories(fs::path(kMapPath).parent_path());
  return SaveMap(trained->map, kMapPath);
}

class FramesTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!fs::exists(kMapPath)) {
      ASSERT_TRUE(TrainFramesMap().ok());
    }
    auto map = LoadMap(kMapPath);
    ASSERT_TRUE(map.ok()) << map.status().ToString();
    map_ = new Map(std::move(map).value());
  }
  static void TearDownTestSuite() { delete map_; }

  // The test pass rendered with `change` applied to the default options.
  static std::vector<cv::Mat> TestPass(void (*change)(TourOptions*)) {
    TourOptions tour;
    tour.num_locations = kLocations;
    change(&tour);
    auto jpegs = RenderTourJpegs(tour, kTestPass);
    EXPECT_TRUE(jpegs.ok());
    std::vector<cv::Mat> images;
    for (const std::string& jpeg : *jpegs) images.push_back(*DecodeImage(jpeg, 8192));
    return images;
  }

  // Each frame's answer, extracting as the server does for a JPEG (the map's frame).
  static std::vector<int> Answers(const std::vector<cv::Mat>& images, float* log_scale = nullptr) {
    const auto extractor = FeatureExtractor::Create(map_->options.extractor);
    std::vector<FeatureSet> sets;
    for (const cv::Mat& image : images) {
      sets.push_back(*extractor->Extract(image, map_->QueryTarget(image.cols, image.rows)));
    }
    return Answers(sets, log_scale);
  }
  // Also gives in *log_scale the median over the frames of the best candidate's median log
  // ratio of query to tour keypoint size: keypoints in the map's frame keep it where the
  // tour camera's own frames have it.
  static std::vector<int> Answers(const std::vector<FeatureSet>& sets, float* log_scale = nullptr) {
    ThreadPool pool(2);
    std::vector<int> answers;
    std::vector<float> scales;
    for (const FeatureSet& f : sets) {
      auto r = Localise(f, *map_, MatchOptions(), &pool);
      EXPECT_TRUE(r.ok()) << r.status().ToString();
      if (!r.ok() || r->candidates.empty()) {
        answers.push_back(-1);
        continue;
      }
      answers.push_back(r->ranked[0].index);
      scales.push_back(r->candidates[0].log_scale);
    }
    if (log_scale != nullptr && !scales.empty()) {
      std::nth_element(scales.begin(), scales.begin() + scales.size() / 2, scales.end());
      *log_scale = scales[scales.size() / 2];
    }
    return answers;
  }
  static int WithinOne(const std::vector<int>& answers) {
    int n = 0;
    for (size_t i = 0; i < answers.size(); ++i) n += std::abs(answers[i] - int(i)) <= 1;
    return n;
  }
  static int Agreeing(const std::vector<int>& a, const std::vector<int>& b) {
    int n = 0;
    for (size_t i = 0; i < a.size(); ++i) n += std::abs(a[i] - b[i]) <= 1;
    return n;
  }

  static Map* map_;
};

Map* FramesTest::map_ = nullptr;

// The map works in a 480x270 frame made from 640x360 tour images.
TEST_F(FramesTest, MapRecordsItsWorkingFrame) {
  EXPECT_EQ(map_->image_width, 480);
  EXPECT_EQ(map_->image_height, 270);
  EXPECT_TRUE((map_->holistic_grid == HolisticGrid{16, 9, 12}));
  EXPECT_EQ(map_->holistic.size(), static_cast<size_t>(kLocations) * 16 * 9 * 12);
}

// JPEGs from a camera of 1.5 times and of half the tour's resolution localise as well as
// the tour camera's and give (nearly) the same answers, with keypoint sizes in the same
// frame (a fixed resize factor would leave the small camera's a factor of 2 off).
TEST_F(FramesTest, QueriesOfOtherResolutionsLocaliseTheSame) {
  float same_scale = 0, smaller_scale = 0;
  const std::vector<int> same = Answers(TestPass([](TourOptions*) {}), &same_scale);
  const std::vector<int> larger = Answers(TestPass([](TourOptions* t) {
    t->image_width = 960;
    t->image_height = 540;
  }));
  const std::vector<int> smaller = Answers(TestPass([](TourOptions* t) {
                                             t->image_width = 320;
                                             t->image_height = 180;
                                           }),
                                           &smaller_scale);
  EXPECT_NEAR(smaller_scale, same_scale, 0.1);
  EXPECT_GE(WithinOne(same), kLocations - 2);
  EXPECT_GE(WithinOne(larger), kLocations - 2);
  EXPECT_GE(WithinOne(smaller), kLocations - 3);
  EXPECT_GE(Agreeing(same, larger), kLocations - 2);
  EXPECT_GE(Agreeing(same, smaller), kLocations - 3);
}

// A feature set a thin client extracted in a frame of its own (640 wide instead of the
// map's 480) is brought into the map's frame and localises as the JPEG does, with keypoint
// sizes in the map's frame (not log(640/480) = 0.29 larger).
TEST_F(FramesTest, FeatureSetsOfAnotherFrameAreRescaled) {
  const std::vector<cv::Mat> images = TestPass([](TourOptions*) {});
  ExtractorOptions client = map_->options.extractor;
  client.working_size = 640;
  const auto extractor = FeatureExtractor::Create(client);
  std::vector<FeatureSet> sets;
  for (const cv::Mat& image : images) {
    sets.push_back(*extractor->ExtractTour(image));
    ASSERT_EQ(sets.back().image_width, 640);
  }
  float rescaled_scale = 0, jpeg_scale = 0;
  const std::vector<int> rescaled = Answers(sets, &rescaled_scale);
  EXPECT_GE(WithinOne(rescaled), kLocations - 2);
  EXPECT_GE(Agreeing(rescaled, Answers(images, &jpeg_scale)), kLocations - 2);
  EXPECT_NEAR(rescaled_scale, jpeg_scale, 0.1);
}

// A much darker test pass (dusk) still localises.
TEST_F(FramesTest, DarkerPassLocalises) {
  const std::vector<int> answers = Answers(TestPass([](TourOptions* t) {
    t->brightness_gain = 0.3;
    t->brightness_offset = -5;
  }));
  EXPECT_GE(WithinOne(answers), kLocations - 3);
}

// A camera of a quarter of the tour's resolution (160x90) still localises.
TEST_F(FramesTest, SmallerCameraLocalises) {
  const std::vector<int> answers = Answers(TestPass([](TourOptions* t) {
    t->image_width = 160;
    t->image_height = 90;
  }));
  EXPECT_GE(WithinOne(answers), kLocations - 4);
}

}  // namespace
}  // namespace sceneloc

int main(int argc, char** argv) {
  if (argc == 2 && std::string(argv[1]) == "--train-map") {
    const sceneloc::Status s = sceneloc::TrainFramesMap();
    std::printf("%s: %s\n", sceneloc::kMapPath.c_str(), s.ToString().c_str());
    return s.ok() ? 0 : 1;
  }
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
