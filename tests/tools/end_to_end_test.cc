// The whole engine on a generated tour: render -> train -> save -> load -> localise each
// frame of the laterally shifted test pass from its JPEG bytes.
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

class EndToEndTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("sceneloc_e2e_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    tour_.num_locations = 30;
    ASSERT_TRUE(WriteTour(tour_, (dir_ / "tour").string(), kTrainingPass).ok());
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
  TourOptions tour_;
};

// Train, save, load, localise: the loaded map equals the trained one in behaviour, and
// most test frames land within one frame of their true location.
TEST_F(EndToEndTest, TrainSaveLoadLocalise) {
  TrainOptions options;
  options.extractor.working_size = 640;  // the generated frames are already small
  auto trained = TrainFromFolder((dir_ / "tour").string(), options, 2, nullptr);
  ASSERT_TRUE(trained.ok()) << trained.status().ToString();
  EXPECT_EQ(trained->summary.images, 30u);
  EXPECT_GT(trained->summary.tracks, 1000u);
  EXPECT_GT(trained->map.num_landmarks(), 1000);

  const std::string path = (dir_ / "synthetic.scnl").string();
  ASSERT_TRUE(SaveMap(trained->map, path).ok());
  auto map = LoadMap(path);
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  EXPECT_EQ(map->image_names, trained->map.image_names);
  EXPECT_EQ(map->provenance.tour_dir, (dir_ / "tour").string());

  auto test_pass = RenderTourJpegs(tour_, kTestPass);
  ASSERT_TRUE(test_pass.ok());
  const auto extractor = FeatureExtractor::Create(map->options.extractor);
  ThreadPool pool(2);
  int within_one = 0, exact = 0;
  for (int i = 0; i < tour_.num_locations; ++i) {
    auto image = DecodeImage((*test_pass)[i], 4096);
    ASSERT_TRUE(image.ok());
    auto features = extractor->Extract(*image, map->QueryTarget(image->cols, image->rows));
    ASSERT_TRUE(features.ok());
    auto result = Localise(*features, *map, MatchOptions(), &pool);
    ASSERT_TRUE(result.ok());
    ASSERT_FALSE(result->ranked.empty());
    const int answer = result->ranked[0].index;
    exact += answer == i;
    within_one += std::abs(answer - i) <= 1;
    EXPECT_GT(result->confidence, 0.0f);
    EXPECT_LE(result->confidence, 1.0f);
  }
  std::printf("synthetic: %d/%d exact, %d/%d within ±1\n", exact, tour_.num_locations, within_one,
              tour_.num_locations);
  EXPECT_GE(within_one, 27);  // >= 90%
}

// The same map trained twice from the same images is the same map (training is
// deterministic, whatever the thread count).
TEST_F(EndToEndTest, TrainingIsDeterministic) {
  TrainOptions options;
  options.extractor.working_size = 640;
  auto a = TrainFromFolder((dir_ / "tour").string(), options, 1, nullptr);
  auto b = TrainFromFolder((dir_ / "tour").string(), options, 2, nullptr);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->map.num_landmarks(), b->map.num_landmarks());
  EXPECT_EQ(a->map.image_landmarks, b->map.image_landmarks);
  EXPECT_TRUE(a->map.local_mean == b->map.local_mean);
  EXPECT_EQ(a->map.quality, b->map.quality);
}

}  // namespace
}  // namespace sceneloc
