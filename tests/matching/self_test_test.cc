#include "common/matching/self_test.h"

#include <gtest/gtest.h>

#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

// Each keypoint of a location's self-test query sits where, and at the size, its landmark
// was seen in that location; its descriptors are the landmark's means as unit rows.
TEST(SelfTestTest, QueryIsTheLocationsOwnLandmarksAsSeenThere) {
  const Map map = test::MakeRandomMap(8, 200, 31);
  for (int l = 0; l < map.num_images(); ++l) {
    const FeatureSet f = SelfTestFeatures(map, l);
    ASSERT_EQ(f.size(), static_cast<int>(map.image_offsets[l + 1] - map.image_offsets[l]));
    EXPECT_EQ(f.image_width, map.image_width);
    EXPECT_TRUE(ValidateFeatureSet(f).ok());
    for (int i = 0; i < f.size(); ++i) {
      const uint32_t g = map.image_landmarks[map.image_offsets[l] + i];
      bool seen_here = false;
      for (uint32_t o = map.observation_offsets[g]; o < map.observation_offsets[g + 1]; ++o) {
        if (map.observation_image[o] != static_cast<uint32_t>(l)) continue;
        EXPECT_EQ(f.keypoints[i].x, map.ObservationX(o));
        EXPECT_EQ(f.keypoints[i].size, map.ObservationSize(o));
        seen_here = true;
      }
      EXPECT_TRUE(seen_here) << "landmark " << g << " of location " << l;
      EXPECT_NEAR(f.local.row(i).norm(), 1.0f, 1e-5f);
      EXPECT_NEAR(f.local.row(i).dot(map.LocalMeanRow(g).normalized()), 1.0f, 1e-5f);
    }
  }
}

// A sound map passes with any number of probes; no probes test nothing.
TEST(SelfTestTest, SoundMapPasses) {
  const Map map = test::MakeRandomMap(12, 300, 32);
  EXPECT_TRUE(SelfTestMap(map, MatchOptions(), 3).ok());
  EXPECT_TRUE(SelfTestMap(map, MatchOptions(), 1).ok());
  EXPECT_TRUE(SelfTestMap(map, MatchOptions(), 100).ok());
  EXPECT_TRUE(SelfTestMap(map, MatchOptions(), 0).ok());
}

// A map whose landmarks were shuffled between locations (statistics no longer belong to the
// images that list them) fails, naming a location.
TEST(SelfTestTest, MapWithMisattributedLandmarksFails) {
  Map map = test::MakeRandomMap(12, 300, 33);
  // Every location's keypoints come from one landmark's observations: rotate the
  // descriptors so each landmark carries another's means.
  const DescriptorBytes local = map.local_mean;
  const DescriptorBytes context = map.context_mean;
  const int n = map.num_landmarks();
  for (int g = 0; g < n; ++g) {
    map.local_mean.row(g) = local.row((g + n / 2) % n);
    map.context_mean.row(g) = context.row((g + n / 2) % n);
  }
  map.Finalize();
  MatchOptions options;
  options.top_k = 1;
  const Status s = SelfTestMap(map, options, 3);
  // The query of a location now carries other locations' descriptors: some probe misses.
  EXPECT_EQ(s.code(), StatusCode::kFailedPrecondition) << s.ToString();
  EXPECT_NE(s.message().find("self-test"), std::string::npos);
}

}  // namespace
}  // namespace sceneloc
