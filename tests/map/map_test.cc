// Map::Validate, Finalize and MemoryBytes, and TrainOptions::Validate.
#include "common/map/map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "common/map/train_options.h"
#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

using test::MakeRandomMap;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// Maps made by the test helper pass Validate for several sizes, including a map with
// no landmarks and a one-image tour.
TEST(MapTest, RandomMapsAreValid) {
  for (const auto& [images, landmarks] :
       std::vector<std::pair<int, int>>{{1, 0}, {1, 5}, {2, 1}, {10, 50}, {40, 300}}) {
    const Map map = MakeRandomMap(images, landmarks, 7);
    EXPECT_TRUE(map.Validate().ok()) << map.Validate().ToString();
    EXPECT_EQ(map.num_images(), images);
    EXPECT_EQ(map.num_landmarks(), landmarks);
  }
}

// Finalize fills local_mean_sqnorm with each landmark's squared descriptor norm,
// checked against a plain loop.
TEST(MapTest, FinalizeComputesSquaredNorms) {
  Map map = MakeRandomMap(8, 40, 3);
  map.local_mean.row(5) = map.local_mean.row(5) / 2;  // a shorter mean (half the norm)
  map.local_mean_sqnorm.clear();
  map.Finalize();
  ASSERT_EQ(map.local_mean_sqnorm.size(), 40u);
  for (int i = 0; i < 40; ++i) {
    double sum = 0;
    for (int j = 0; j < kDescriptorSize; ++j)
      sum += std::pow(double{UnitValue(map.local_mean(i, j))}, 2);
    EXPECT_NEAR(map.local_mean_sqnorm[i], sum, 1e-5 * sum) << "landmark " << i;
  }
  EXPECT_NEAR(map.local_mean_sqnorm[5], 0.25f, 0.01f);
}

// MemoryBytes counts at least the descriptor matrices and grows with the map.
TEST(MapTest, MemoryBytesCoversTheArrays) {
  const Map small = MakeRandomMap(10, 20, 1);
  const Map large = MakeRandomMap(10, 400, 1);
  // Two byte descriptors and two half-float spreads per landmark (compact.h).
  const size_t descriptors = 400 * (2 * kDescriptorSize + 2 * kNumHistograms * sizeof(uint16_t));
  EXPECT_GE(large.MemoryBytes(), descriptors);
  EXPECT_GT(large.MemoryBytes(), small.MemoryBytes());
}

// One way to break a valid map, and the words its error must contain.
struct Breakage {
  std::string name;
  std::function<void(Map*)> apply;
  std::string expected_message;
};

class MapValidateTest : public ::testing::TestWithParam<Breakage> {};

// Validate reports each kind of inconsistency as DataLoss naming what is wrong.
TEST_P(MapValidateTest, RejectsInconsistency) {
  Map map = MakeRandomMap(12, 60, 11);
  ASSERT_TRUE(map.Validate().ok());
  GetParam().apply(&map);
  const Status status = map.Validate();
  EXPECT_EQ(status.code(), StatusCode::kDataLoss) << status.ToString();
  EXPECT_NE(status.message().find(GetParam().expected_message), std::string::npos)
      << status.message();
}

// The first landmark with at least one neighbour.
int LandmarkWithNeighbour(const Map& map) {
  for (int g = 0; g < map.num_landmarks(); ++g) {
    if (map.neighbour_offsets[g + 1] > map.neighbour_offsets[g]) return g;
  }
  return -1;
}

std::vector<Breakage> Breakages() {
  return {
      {"InvalidOptions", [](Map* m) { m->options.ransac_confidence = 1.5; },
       "training options: tracking.ransac_confidence = 1.5 is outside [0.5, 0.999999]"},
      {"NoImages", [](Map* m) { m->image_names.clear(); }, "no tour images"},
      {"EmptyImageName", [](Map* m) { m->image_names[3].clear(); }, "image_names[3] is empty"},
      {"ZeroWidth", [](Map* m) { m->image_width = 0; }, "image size 0x270"},
      {"ShortLandmarkArray", [](Map* m) { m->local_var.pop_back(); },
       "local_var has 59 entries but the map has 60 landmarks"},
      {"ShortContextMatrix", [](Map* m) { m->context_var.conservativeResize(59, kNumHistograms); },
       "context_var has 59 entries"},
      {"ShortQuality", [](Map* m) { m->quality.push_back(1); }, "quality has 61 entries"},
      {"OffsetsWrongLength", [](Map* m) { m->observation_offsets.pop_back(); },
       "observation_offsets has 60 entries, expected 61"},
      {"OffsetsNotFromZero", [](Map* m) { m->neighbour_offsets[0] = 1; },
       "neighbour_offsets starts at 1, expected 0"},
      {"OffsetsDecrease",
       [](Map* m) { m->observation_offsets[10] = m->observation_offsets[11] + 1; },
       "observation_offsets decreases"},
      {"OffsetsEndEarly", [](Map* m) { m->image_landmarks.push_back(0); }, "image_offsets ends at"},
      {"ObservationArraysDiffer", [](Map* m) { m->observations.pop_back(); }, "observations has"},
      {"ObservationImageOutOfRange",
       [](Map* m) { m->observation_image[m->observation_offsets[4] + 1] = 12; },
       "observation 1 of landmark 4 refers to image 12 but the map has 12 images"},
      {"NeighbourOutOfRange",
       [](Map* m) {
         const int g = LandmarkWithNeighbour(*m);
         m->neighbours[m->neighbour_offsets[g]].landmark = 99999;
       },
       "refers to landmark 99999 but the map has 60 landmarks"},
      {"ImageLandmarkOutOfRange", [](Map* m) { m->image_landmarks.back() = 60; },
       "refers to landmark 60 but the map has 60 landmarks"},
      {"ZeroContextVariance", [](Map* m) { m->context_var(2, 3) = 0; },
       "context_var[2][3] is 0, must be finite and > 0"},
      {"ZeroVariance", [](Map* m) { m->local_var[9] = 0; },
       "local_var[9] is 0, must be finite and > 0"},
      {"NegativeDmax", [](Map* m) { m->local_dmax[0] = -0.5f; }, "local_dmax[0] is -0.5"},
      {"NaNObservation", [](Map* m) { m->observations[5].size = HalfBits(kNaN); },
       "observation_size[5] is nan"},
      {"InfiniteQuality", [](Map* m) { m->quality[2] = kInf; }, "quality[2] is inf"},
      {"ZeroDistanceVariance", [](Map* m) { m->neighbours[1].distance_sd = 0; },
       "neighbours[1].distance_var is 0"},
      {"ZeroAngleVariance", [](Map* m) { m->neighbours[2].angle_sd = 0; },
       "neighbours[2].angle_var is 0"},
      {"LookAlikesWithoutOffsets", [](Map* m) { m->lookalike_location = {1}; },
       "look-alikes without their offsets"},
      {"LookAlikeOffsetsShort",
       [](Map* m) {
         m->lookalike_offsets.assign(12, 0);  // one short of the 12 images
       },
       "look-alike lists do not match the places"},
      {"LookAlikeOutOfRange",
       [](Map* m) {
         m->lookalike_offsets.assign(13, 1);
         m->lookalike_offsets[0] = 0;
         m->lookalike_location = {12};
         m->lookalike_ratio = {0.5f};
       },
       "look-alike 0 names no place"},
      {"LookAlikeRatioZero",
       [](Map* m) {
         m->lookalike_offsets.assign(13, 1);
         m->lookalike_offsets[0] = 0;
         m->lookalike_location = {3};
         m->lookalike_ratio = {0.0f};
       },
       "its ratio is outside (0, 1]"},
      {"ImagePlaceShort", [](Map* m) { m->image_place.assign(11, 0); },
       "image_place has 11 entries for 12 images"},
      {"PlaceSkipped", [](Map* m) { m->image_place = {0, 1, 2, 3, 4, 5, 7, 6, 8, 9, 10, 11}; },
       "image 6 shows place 7 before any image shows place 6"},
      {"ExperiencesShort",
       [](Map* m) {
         m->experiences = {{"tour", "", "", ExperienceKind::kTour, 0, 11, 11}};
       },
       "the experiences cover 11 images of 12"},
      {"ExperienceGap",
       [](Map* m) {
         m->experiences = {{"tour", "", "", ExperienceKind::kTour, 0, 6, 6},
                           {"night", "", "", ExperienceKind::kRoute, 7, 5, 9}};
       },
       "experience 1 ('night') does not follow the one before it"},
      {"SecondTour",
       [](Map* m) {
         m->experiences = {{"tour", "", "", ExperienceKind::kTour, 0, 6, 6},
                           {"again", "", "", ExperienceKind::kTour, 6, 6, 6}};
       },
       "the first experience, and only it, is the tour"},
      {"LookAlikesOfImagesNotPlaces",
       [](Map* m) {
         m->image_place = {0, 1, 2, 3, 4, 5, 0, 1, 2, 3, 4, 5};  // 6 places, 12 images
         m->lookalike_offsets.assign(13, 0);
       },
       "look-alike lists do not match the places"},
  };
}

INSTANTIATE_TEST_SUITE_P(Breakages, MapValidateTest, ::testing::ValuesIn(Breakages()),
                         [](const auto& info) { return info.param.name; });

// The default training options are valid.
TEST(TrainOptionsTest, DefaultsAreValid) {
  const TrainOptions options;
  EXPECT_TRUE(options.Validate().ok()) << options.Validate().ToString();
}

// The range limits themselves are accepted where the range is closed.
TEST(TrainOptionsTest, AcceptsClosedBounds) {
  TrainOptions options;
  options.track_distance_threshold = 2.0;
  options.min_links_per_pair = 8;
  options.quality_fp_prior = 0;
  options.eta = 0;
  options.q_min = 0;
  options.max_neighbours = 256;
  EXPECT_TRUE(options.Validate().ok()) << options.Validate().ToString();
  options.max_neighbours = 0;
  EXPECT_TRUE(options.Validate().ok()) << options.Validate().ToString();
}

struct BadOption {
  std::string name;
  std::function<void(TrainOptions*)> apply;
  std::string expected_message;
};

class TrainOptionsValidateTest : public ::testing::TestWithParam<BadOption> {};

// Each out-of-range value is InvalidArgument naming the field as a settings file does
// (section.key), its value and its declared range.
TEST_P(TrainOptionsValidateTest, RejectsOutOfRange) {
  TrainOptions options;
  GetParam().apply(&options);
  const Status status = options.Validate();
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << status.ToString();
  EXPECT_NE(status.message().find(GetParam().expected_message), std::string::npos)
      << status.message();
}

std::vector<BadOption> BadOptions() {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  return {
      {"WorkingSize", [](TrainOptions* o) { o->extractor.working_size = 20; },
       "extractor.working_size = 20 is outside [64, 4096] pixels"},
      {"HolisticBins", [](TrainOptions* o) { o->extractor.holistic.bins = 2; },
       "extractor.holistic_bins = 2 is outside [4, 36]"},
      {"TrackThresholdZero", [](TrainOptions* o) { o->track_distance_threshold = 0; },
       "tracking.distance_threshold = 0 is outside [1e-06, 2]"},
      {"TrackThresholdAboveTwo", [](TrainOptions* o) { o->track_distance_threshold = 2.5; },
       "tracking.distance_threshold = 2.5 is outside [1e-06, 2]"},
      {"TrackThresholdNaN", [nan](TrainOptions* o) { o->track_distance_threshold = nan; },
       "tracking.distance_threshold = nan is outside [1e-06, 2]"},
      {"RansacThreshold", [](TrainOptions* o) { o->ransac_threshold = 0; },
       "tracking.ransac_threshold = 0 is outside [1e-05, 0.1]"},
      {"RansacConfidenceOne", [](TrainOptions* o) { o->ransac_confidence = 1; },
       "tracking.ransac_confidence = "},
      {"RansacConfidenceZero", [](TrainOptions* o) { o->ransac_confidence = 0; },
       "tracking.ransac_confidence = "},
      {"MinLinks", [](TrainOptions* o) { o->min_links_per_pair = 7; },
       "tracking.min_links_per_pair = 7 is outside [8, 100000]"},
      {"LocalVarFloor", [](TrainOptions* o) { o->local_var_floor = 0; },
       "landmarks.local_var_floor = 0 is outside [1e-09, 4]"},
      {"ContextVarFloor", [](TrainOptions* o) { o->context_var_floor = -1; },
       "landmarks.context_var_floor = -1 is outside [1e-09, 4]"},
      {"DistanceSdFloor", [](TrainOptions* o) { o->distance_sd_floor = 0; },
       "landmarks.distance_sd_floor = 0 is outside [1e-05, 1]"},
      {"AngleVarFloor", [nan](TrainOptions* o) { o->angle_var_floor = nan; },
       "landmarks.angle_var_floor = nan is outside [1e-09, 40] radians^2"},
      {"QualitySMinOne", [](TrainOptions* o) { o->quality_s_min = 1; },
       "selection.quality_s_min = "},
      {"QualitySMinZero", [](TrainOptions* o) { o->quality_s_min = 0; },
       "selection.quality_s_min = "},
      {"FpPrior", [](TrainOptions* o) { o->quality_fp_prior = -0.1; },
       "selection.quality_fp_prior = -0.1 is outside [0, 1000000000]"},
      {"Eta", [](TrainOptions* o) { o->eta = -1; }, "selection.eta = -1 is outside [0, 1000000]"},
      {"QMin", [](TrainOptions* o) { o->q_min = -0.01; },
       "selection.q_min = -0.01 is outside [0, 1000000000]"},
      {"MaxNeighboursNegative", [](TrainOptions* o) { o->max_neighbours = -1; },
       "landmarks.max_neighbours = -1 is outside [0, 256]"},
      {"MaxNeighboursLarge", [](TrainOptions* o) { o->max_neighbours = 257; },
       "landmarks.max_neighbours = 257 is outside [0, 256]"},
  };
}

INSTANTIATE_TEST_SUITE_P(BadOptions, TrainOptionsValidateTest, ::testing::ValuesIn(BadOptions()),
                         [](const auto& info) { return info.param.name; });

}  // namespace
}  // namespace sceneloc
