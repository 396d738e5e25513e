#include "common/synthetic/tour_generator.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace sceneloc {
namespace {

TourOptions SmallTour(int num_locations, uint32_t seed = 1) {
  TourOptions options;
  options.num_locations = num_locations;
  options.seed = seed;
  return options;
}

std::vector<std::string> Render(const TourOptions& options, int pass) {
  StatusOr<std::vector<std::string>> jpegs = RenderTourJpegs(options, pass);
  EXPECT_TRUE(jpegs.ok()) << jpegs.status().ToString();
  return jpegs.ok() ? *jpegs : std::vector<std::string>();
}

cv::Mat Decode(const std::string& jpeg, int flags = cv::IMREAD_COLOR) {
  return cv::imdecode(std::vector<uchar>(jpeg.begin(), jpeg.end()), flags);
}

double MeanAbsDifference(const std::string& a, const std::string& b) {
  cv::Mat diff;
  cv::absdiff(Decode(a, cv::IMREAD_GRAYSCALE), Decode(b, cv::IMREAD_GRAYSCALE), diff);
  return cv::mean(diff)[0];
}

std::string ReadFile(const std::filesystem::path& path) {
  std::ifstream file(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(file), {});
}

// A fresh directory under the test temp dir, removed at the end of the test.
class ScratchDir {
 public:
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::path(::testing::TempDir()) /
            ("sceneloc_synthetic_" + std::to_string(getpid()) + "_" + info->name());
    std::filesystem::remove_all(path_);
  }
  ~ScratchDir() { std::filesystem::remove_all(path_); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// The same options give byte-identical JPEGs, call after call, in both passes.
TEST(TourGeneratorTest, SameSeedGivesIdenticalBytes) {
  const TourOptions options = SmallTour(4, 7);
  for (int pass : {kTrainingPass, kTestPass}) {
    const std::vector<std::string> first = Render(options, pass);
    const std::vector<std::string> second = Render(options, pass);
    ASSERT_EQ(first.size(), 4u);
    EXPECT_EQ(first, second) << "pass " << pass;
  }
}

// Another seed draws another scene: the images differ far beyond sensor noise.
TEST(TourGeneratorTest, DifferentSeedGivesDifferentScene) {
  const std::vector<std::string> one = Render(SmallTour(3, 1), kTrainingPass);
  const std::vector<std::string> two = Render(SmallTour(3, 2), kTrainingPass);
  ASSERT_EQ(one.size(), 3u);
  ASSERT_EQ(two.size(), 3u);
  for (size_t i = 0; i < one.size(); ++i) {
    EXPECT_GT(MeanAbsDifference(one[i], two[i]), 20.0) << "location " << i;
  }
}

// Location i does not depend on the tour's length, so a short tour is a prefix of a long.
TEST(TourGeneratorTest, ShorterTourIsAPrefixOfALongerOne) {
  for (int pass : {kTrainingPass, kTestPass}) {
    const std::vector<std::string> short_tour = Render(SmallTour(3), pass);
    const std::vector<std::string> long_tour = Render(SmallTour(8), pass);
    ASSERT_EQ(long_tour.size(), 8u);
    EXPECT_EQ(short_tour, std::vector<std::string>(long_tour.begin(), long_tour.begin() + 3));
  }
}

// A street of repeated blocks: a location looks like the one a block further on (only a
// small sign per facade tile differs), and unlike locations half a block away; without
// repeats the location a block on is another scene.
TEST(TourGeneratorTest, RepeatedBlocksMakeLookAlikePlaces) {
  TourOptions options = SmallTour(16);
  options.step = 0.4;  // 4 m a location: a 40 m block is 10 locations
  options.noise_stddev = 0;
  options.repeat_blocks = 1;
  const std::vector<std::string> repeated = Render(options, kTrainingPass);
  options.repeat_blocks = 0;
  const std::vector<std::string> plain = Render(options, kTrainingPass);
  ASSERT_EQ(repeated.size(), 16u);
  for (int i = 0; i < 6; ++i) {
    const double twin = MeanAbsDifference(repeated[i], repeated[i + 10]);
    EXPECT_GT(twin, 0.0) << "location " << i << ": its signs should differ";
    EXPECT_LT(twin, 6.0) << "location " << i;
    EXPECT_GT(MeanAbsDifference(repeated[i], repeated[i + 5]), 4 * twin) << "location " << i;
    EXPECT_GT(MeanAbsDifference(plain[i], plain[i + 10]), 4 * twin) << "location " << i;
  }
}

// Every image is a colour JPEG of the requested size, for several sizes and both passes.
TEST(TourGeneratorTest, ImagesDecodeToTheRequestedSize) {
  for (const cv::Size size : {cv::Size(640, 360), cv::Size(320, 240), cv::Size(161, 90)}) {
    TourOptions options = SmallTour(2);
    options.image_width = size.width;
    options.image_height = size.height;
    for (int pass : {kTrainingPass, kTestPass}) {
      for (const std::string& jpeg : Render(options, pass)) {
        const cv::Mat image = Decode(jpeg);
        ASSERT_FALSE(image.empty());
        EXPECT_EQ(image.size(), size);
        EXPECT_EQ(image.channels(), 3);
      }
    }
  }
}

// The facade fills every view the options allow, even 4:3 images at the extremes of the
// test-pass geometry: no pixel shows the renderer's grey outside the textured world.
TEST(TourGeneratorTest, FacadeFillsEveryAllowedView) {
  struct Extreme {
    double lateral_shift, rotation_deg;
  };
  for (const Extreme extreme : {Extreme{-0.3, -5}, Extreme{-0.3, 10}, Extreme{0.3, -5}}) {
    TourOptions options = SmallTour(2);
    options.image_width = 640;
    options.image_height = 480;
    options.lateral_shift = extreme.lateral_shift;
    options.rotation_deg = extreme.rotation_deg;
    options.brightness_gain = 1;
    options.brightness_offset = 0;
    options.noise_stddev = 0;
    for (const std::string& jpeg : Render(options, kTestPass)) {
      const cv::Mat image = Decode(jpeg);
      cv::Mat grey;
      cv::inRange(image, cv::Scalar::all(128), cv::Scalar::all(128), grey);
      EXPECT_LT(cv::countNonZero(grey), image.total() / 1000)
          << "lateral_shift " << extreme.lateral_shift << ", rotation " << extreme.rotation_deg;
    }
  }
}

// The test pass shows each location from elsewhere and in other light, not the training
// image plus noise (which would make the localisation check below meaningless).
TEST(TourGeneratorTest, TestPassSeesEachLocationDifferently) {
  const TourOptions options = SmallTour(3);
  const std::vector<std::string> training = Render(options, kTrainingPass);
  const std::vector<std::string> test = Render(options, kTestPass);
  ASSERT_EQ(test.size(), 3u);
  for (size_t i = 0; i < test.size(); ++i) {
    EXPECT_GT(MeanAbsDifference(training[i], test[i]), 20.0) << "location " << i;
    const double training_mean = cv::mean(Decode(training[i], cv::IMREAD_GRAYSCALE))[0];
    const double test_mean = cv::mean(Decode(test[i], cv::IMREAD_GRAYSCALE))[0];
    EXPECT_GT(std::abs(test_mean - training_mean), 5.0) << "location " << i;
  }
}

// WriteTour creates the folder and writes exactly the rendered JPEGs, named in order.
TEST(TourGeneratorTest, WriteTourWritesNumberedImages) {
  const ScratchDir scratch;
  const std::filesystem::path dir = scratch.path() / "nested" / "tour";
  const TourOptions options = SmallTour(3);
  ASSERT_TRUE(WriteTour(options, dir.string(), kTestPass).ok());
  const std::vector<std::string> expected = Render(options, kTestPass);
  ASSERT_EQ(expected.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(ReadFile(dir / TourImageName(i)), expected[i]) << TourImageName(i);
  }
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 3);
  EXPECT_EQ(TourImageName(0), "Image000.jpg");
  EXPECT_EQ(TourImageName(1234), "Image1234.jpg");
}

// Several threads write the same images as one: each renders a run of locations.
TEST(TourGeneratorTest, WriteTourInThreadsWritesTheSameImages) {
  const ScratchDir scratch;
  const TourOptions options = SmallTour(7);
  ASSERT_TRUE(WriteTour(options, scratch.path().string(), kTrainingPass, 3).ok());
  const std::vector<std::string> expected = Render(options, kTrainingPass);
  for (int i = 0; i < 7; ++i) {
    EXPECT_EQ(ReadFile(scratch.path() / TourImageName(i)), expected[i]) << TourImageName(i);
  }
}

// A folder that cannot be created is an I/O error naming it, not a crash.
TEST(TourGeneratorTest, WriteTourReportsAFolderItCannotCreate) {
  const ScratchDir scratch;
  std::filesystem::create_directories(scratch.path());
  const std::filesystem::path file = scratch.path() / "a_file";
  std::ofstream(file) << "not a folder";
  const Status status = WriteTour(SmallTour(2), (file / "tour").string(), kTrainingPass);
  EXPECT_EQ(status.code(), StatusCode::kIoError);
  EXPECT_NE(status.message().find("a_file"), std::string::npos) << status.message();
}

// Each out-of-range setting, and a pass other than 0 or 1, is refused before anything is
// rendered or written.
TEST(TourGeneratorTest, InvalidOptionsAreRejected) {
  EXPECT_TRUE(TourOptions().Validate().ok());
  const std::vector<std::function<void(TourOptions*)>> breakers = {
      [](TourOptions* o) { o->num_locations = 0; },
      [](TourOptions* o) { o->image_width = 100; },
      [](TourOptions* o) { o->image_height = 8; },
      [](TourOptions* o) { o->image_height = o->image_width; },  // portrait/square
      [](TourOptions* o) { o->step = 0; },
      [](TourOptions* o) { o->step = std::nan(""); },
      [](TourOptions* o) { o->lateral_shift = 0.5; },
      [](TourOptions* o) { o->forward_offset = -0.7; },
      [](TourOptions* o) { o->rotation_deg = 45; },
      [](TourOptions* o) { o->rotation_deg = -6; },
      [](TourOptions* o) { o->brightness_gain = 0; },
      [](TourOptions* o) { o->brightness_offset = 300; },
      [](TourOptions* o) { o->noise_stddev = -1; },
      [](TourOptions* o) { o->jpeg_quality = 101; },
      [](TourOptions* o) { o->repeat_blocks = -1; },
      [](TourOptions* o) { o->repeat_blocks = 1001; },
  };
  const ScratchDir scratch;
  for (size_t i = 0; i < breakers.size(); ++i) {
    TourOptions options = SmallTour(2);
    breakers[i](&options);
    EXPECT_EQ(options.Validate().code(), StatusCode::kInvalidArgument) << "case " << i;
    EXPECT_EQ(RenderTourJpegs(options, kTrainingPass).status().code(), StatusCode::kInvalidArgument)
        << "case " << i;
    EXPECT_EQ(WriteTour(options, scratch.path().string(), kTrainingPass).code(),
              StatusCode::kInvalidArgument)
        << "case " << i;
  }
  EXPECT_FALSE(std::filesystem::exists(scratch.path()));
  for (int pass : {-1, 2}) {
    EXPECT_EQ(RenderTourJpegs(SmallTour(2), pass).status().code(), StatusCode::kInvalidArgument);
  }
}

// ---------------------------------------------------------------------------------------
// What the engine relies on: SIFT finds, tracks and re-finds the scene's features.

struct SiftPass {
  std::vector<std::vector<cv::KeyPoint>> keypoints;
  std::vector<cv::Mat> descriptors;
};

// Default OpenCV SIFT, keeping the 1000 strongest features per image as the engine does.
SiftPass ExtractSift(const std::vector<std::string>& jpegs) {
  const cv::Ptr<cv::SIFT> sift = cv::SIFT::create(1000);
  SiftPass pass;
  for (const std::string& jpeg : jpegs) {
    pass.keypoints.emplace_back();
    pass.descriptors.emplace_back();
    sift->detectAndCompute(Decode(jpeg, cv::IMREAD_GRAYSCALE), cv::noArray(), pass.keypoints.back(),
                           pass.descriptors.back());
  }
  return pass;
}

// Matches of `query` features whose nearest `train` feature passes Lowe's ratio test.
int RatioTestMatches(const cv::Mat& query, const cv::Mat& train) {
  if (query.rows < 1 || train.rows < 2) return 0;
  std::vector<std::vector<cv::DMatch>> knn;
  cv::BFMatcher(cv::NORM_L2).knnMatch(query, train, knn, 2);
  return static_cast<int>(std::count_if(knn.begin(), knn.end(), [](const auto& m) {
    return m.size() == 2 && m[0].distance < 0.8f * m[1].distance;
  }));
}

class TourGeneratorSiftTest : public ::testing::Test {
 protected:
  static constexpr int kLocations = 20;

  // Rendering and SIFT are the slow part: each pass is done once per process, when a
  // test first needs it (ctest runs each test in a process of its own).
  static const SiftPass& Training() { return Pass(kTrainingPass); }
  static const SiftPass& Test() { return Pass(kTestPass); }

 private:
  static const SiftPass& Pass(int pass) {
    static SiftPass passes[2];
    static bool done[2] = {false, false};
    if (!done[pass]) {
      passes[pass] = ExtractSift(Render(SmallTour(kLocations), pass));
      done[pass] = true;
    }
    return passes[pass];
  }
};

// Every frame of both passes has plenty of SIFT keypoints at 640x360.
TEST_F(TourGeneratorSiftTest, EveryFrameHasAtLeast300Keypoints) {
  for (int pass : {kTrainingPass, kTestPass}) {
    const SiftPass& sift = pass == kTrainingPass ? Training() : Test();
    ASSERT_EQ(sift.keypoints.size(), static_cast<size_t>(kLocations));
    for (int i = 0; i < kLocations; ++i) {
      EXPECT_GE(sift.keypoints[i].size(), 300u) << "pass " << pass << ", location " << i;
    }
  }
}

// Consecutive training frames share enough features for the trainer to track them.
TEST_F(TourGeneratorSiftTest, ConsecutiveTrainingFramesShareAtLeast100Matches) {
  for (int i = 0; i + 1 < kLocations; ++i) {
    EXPECT_GE(RatioTestMatches(Training().descriptors[i], Training().descriptors[i + 1]), 100)
        << "training " << i << " -> " << i + 1;
  }
}

// Test frame i matches training frame i (+-1) best, and frames 3 or more locations away
// clearly worse: the scene is localisable and not periodic.
TEST_F(TourGeneratorSiftTest, TestFramesMatchTheirOwnLocationBest) {
  int within_one = 0, exact = 0, distinct = 0;
  std::ostringstream report;
  for (int i = 0; i < kLocations; ++i) {
    std::vector<int> matches(kLocations);
    for (int j = 0; j < kLocations; ++j) {
      matches[j] = RatioTestMatches(Test().descriptors[i], Training().descriptors[j]);
    }
    const int best =
        static_cast<int>(std::max_element(matches.begin(), matches.end()) - matches.begin());
    int near = 0, far = 0;
    for (int j = 0; j < kLocations; ++j) {
      const int distance = std::abs(j - i);
      if (distance <= 1) near = std::max(near, matches[j]);
      if (distance >= 3) far = std::max(far, matches[j]);
    }
    within_one += std::abs(best - i) <= 1;
    exact += best == i;
    distinct += near >= 1.5 * far;
    report << " " << i << "->" << best << " (" << near << " vs " << far << ")";
  }
  RecordProperty("within_one", within_one);
  RecordProperty("exact", exact);
  EXPECT_GE(within_one, 0.9 * kLocations) << "test -> best training (near vs far):" << report.str();
  EXPECT_GE(distinct, 0.9 * kLocations) << "test -> best training (near vs far):" << report.str();
  std::printf("best training match within +-1: %d/%d, exact: %d/%d\n", within_one, kLocations,
              exact, kLocations);
}

}  // namespace
}  // namespace sceneloc
