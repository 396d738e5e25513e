// The scale regression floor CI keeps (scripts/bench_scale.sh measures 200, 2,000 and 20,000
// locations; this is its small slice): a generated tour of 2,000 locations, trained the way
// sceneloc-train trains it (streamed through a feature spool, Q in windows) with the shipped
// settings, written to disk and read back, then asked by frames of the test pass. It fails
// when the map stops carrying its place index, grows per location, or when the coarse stage
// stops finding the places the whole map finds.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "common/config/config.h"
#include "common/map/map_io.h"
#include "common/matching/localiser.h"
#include "common/training/trainer.h"
#include "common/util/image_folder.h"
#include "tests/support/scratch_dir.h"
#include "tests/support/tour_features.h"

namespace sceneloc {
namespace {

constexpr int kLocations = 2000;
constexpr int kQueryStep = 50;  // every 50th frame of the test pass: 40 queries

TEST(ScaleSliceTest, TwoThousandLocationsTrainStreamedAndAnswerThroughThePlaceIndex) {
  const test::ScratchDir dir{"scale_slice"};
  const TourOptions tour = test::SmallTour(kLocations, 11);
  ASSERT_TRUE(WriteTour(tour, dir.File("tour"), kTrainingPass, 2).ok());
  TrainOptions options;
  ASSERT_TRUE(LoadTrainOptions(SCENELOC_CONFIGS_DIR "/train.yaml", &options).ok());
  MatchOptions match;
  ASSERT_TRUE(LoadMatchOptions(SCENELOC_CONFIGS_DIR "/match.yaml", &match).ok());

  auto trained = TrainFromFolder(dir.File("tour"), options, 2, nullptr, dir.path().string());
  ASSERT_TRUE(trained.ok()) << trained.status().ToString();
  ASSERT_TRUE(SaveMap(trained->map, dir.File("slice.scnl")).ok());
  auto loaded = LoadMap(dir.File("slice.scnl"));
  ASSERT_TRUE(loaded.ok()) << loaded.status().ToString();
  const Map& map = *loaded;
  EXPECT_EQ(map.num_images(), kLocations);
  EXPECT_EQ(map.num_landmarks(), trained->map.num_landmarks());
  ASSERT_TRUE(map.has_place_index());
  EXPECT_FALSE(map.keeps_projections());
  const double kb_per_location = static_cast<double>(map.MemoryBytes()) / 1024.0 / kLocations;
  RecordProperty("kb_per_location", std::to_string(kb_per_location));
  EXPECT_LT(kb_per_location, 40.0);  // 36 when this floor was set (30 is the target)

  // The test pass's frames, in the map's frame, against the coarse stage and the whole map.
  ASSERT_TRUE(WriteTour(tour, dir.File("test"), kTestPass, 2).ok());
  auto extractor = FeatureExtractor::Create(options.extractor);
  MatchOptions whole = match;
  whole.use_place_index = false;
  int right = 0, same = 0, queries = 0;
  for (int q = kQueryStep / 2; q < kLocations; q += kQueryStep) {
    auto image = ReadImageFile(dir.File("test") + "/" + TourImageName(q));
    ASSERT_TRUE(image.ok()) << image.status().ToString();
    auto features = extractor->Extract(*image, map.QueryTarget(image->cols, image->rows));
    ASSERT_TRUE(features.ok()) << features.status().ToString();
    auto coarse = Localise(*features, map, match, nullptr);
    auto exhaustive = Localise(*features, map, whole, nullptr);
    ASSERT_TRUE(coarse.ok() && exhaustive.ok());
    ++queries;
    right += std::abs(coarse->ranked[0].index - q) <= options.tolerance;
    same += coarse->ranked[0].index == exhaustive->ranked[0].index;
  }
  RecordProperty("within_tolerance", right);
  RecordProperty("same_as_whole_map", same);
  std::printf(
      "scale slice: %d locations, %d landmarks, %.1f KB/location; of %d queries %d within "
      "±%d, %d answered as the whole map\n",
      map.num_images(), map.num_landmarks(), kb_per_location, queries, right, options.tolerance,
      same);
  EXPECT_GE(right, queries * 8 / 10);
  EXPECT_GE(same, queries * 9 / 10);
}

}  // namespace
}  // namespace sceneloc
