// Extraction on the robot (client/client_extractor.h): in the map's frame from a map file,
// in the tour frame from training settings or the defaults, and each bad source refused.
#include "client/client_extractor.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "common/map/map_io.h"
#include "common/synthetic/tour_generator.h"
#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

class ClientExtractorTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) /
           ("client_extractor_test_" + std::to_string(::getpid()) + "_" + test->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Location 0 of a generated 640x360 tour.
  static cv::Mat Image() {
    TourOptions tour;
    tour.num_locations = 1;
    const auto jpegs = RenderTourJpegs(tour, kTrainingPass);
    EXPECT_TRUE(jpegs.ok());
    const std::string& jpeg = jpegs->front();
    return cv::imdecode(std::vector<uchar>(jpeg.begin(), jpeg.end()), cv::IMREAD_COLOR);
  }
  StatusOr<FeatureSet> Extract(const ClientExtractorSource& source) const {
    SCENELOC_ASSIGN_OR_RETURN(const ClientExtractor extractor, ClientExtractor::Create(source));
    return extractor.Extract(Image());
  }

  fs::path dir_;
};

// From a map file: the map's own settings, every image brought into the map's working
// frame (its width) and holistic grid, as the server would.
TEST_F(ClientExtractorTest, MapFileGivesTheMapsFrame) {
  Map map = test::MakeRandomMap(3, 20, 1);  // a 480x270 frame
  map.options.extractor.max_features = 150;
  const std::string path = (dir_ / "lab.scnl").string();
  ASSERT_TRUE(SaveMap(map, path).ok());
  ClientExtractorSource source;
  source.map_file = path;
  const auto extractor = ClientExtractor::Create(source);
  ASSERT_TRUE(extractor.ok()) << extractor.status().ToString();
  EXPECT_EQ(extractor->options().max_features, 150);
  const StatusOr<FeatureSet> f = extractor->Extract(Image());
  ASSERT_TRUE(f.ok()) << f.status().ToString();
  EXPECT_EQ(f->image_width, 480);
  EXPECT_EQ(f->image_height, 270);
  EXPECT_TRUE(f->holistic_grid == map.holistic_grid);
  EXPECT_GT(f->size(), 0);
  EXPECT_LE(f->size(), 150);
  EXPECT_EQ(extractor->Extract(cv::Mat()).status().code(), StatusCode::kInvalidArgument);
}

// From training settings, with a working size over them, or from the defaults: each image
// in its own tour frame (long side = working_size).
TEST_F(ClientExtractorTest, SettingsGiveTheTourFrame) {
  const std::string config = (dir_ / "train.yaml").string();
  std::ofstream(config) << "extractor:\n  working_size: 320\n";
  ClientExtractorSource source;
  source.config = config;
  StatusOr<FeatureSet> f = Extract(source);
  ASSERT_TRUE(f.ok()) << f.status().ToString();
  EXPECT_EQ(f->image_width, 320);
  EXPECT_EQ(f->image_height, 180);
  source.working_size = 160;
  f = Extract(source);
  ASSERT_TRUE(f.ok()) << f.status().ToString();
  EXPECT_EQ(f->image_width, 160);
  f = Extract(ClientExtractorSource());
  ASSERT_TRUE(f.ok()) << f.status().ToString();
  EXPECT_EQ(f->image_width, ExtractorOptions().working_size);
}

// A working size cannot override a map's frame; a missing map file, an unreadable
// settings file and an invalid working size are refused.
TEST_F(ClientExtractorTest, RefusesBadSources) {
  ClientExtractorSource with_map;
  with_map.map_file = (dir_ / "absent.scnl").string();
  EXPECT_EQ(ClientExtractor::Create(with_map).status().code(), StatusCode::kNotFound);
  with_map.working_size = 320;
  EXPECT_EQ(ClientExtractor::Create(with_map).status().code(), StatusCode::kInvalidArgument);
  ClientExtractorSource with_config;
  with_config.config = (dir_ / "absent.yaml").string();
  EXPECT_FALSE(ClientExtractor::Create(with_config).ok());
  ClientExtractorSource tiny;
  tiny.working_size = 10;
  EXPECT_EQ(ClientExtractor::Create(tiny).status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace sceneloc
