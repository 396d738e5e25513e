// Holistic distances of a query to every tour image (common/matching/holistic_similarity.h),
// against HolisticDistance called image by image, with and without a thread pool.
#include "common/matching/holistic_similarity.h"

#include <gtest/gtest.h>

#include "common/features/holistic.h"
#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

// A query whose holistic descriptor is tour image `image`'s.
FeatureSet QueryLike(const Map& map, int image) {
  FeatureSet query;
  query.holistic_grid = map.holistic_grid;
  query.holistic = map.HolisticValues(image);
  return query;
}

// One distance per tour image, each what HolisticDistance gives for that image; zero at
// the image the query copies.
TEST(HolisticSimilarityTest, MatchesPerImageDistances) {
  const Map map = test::MakeRandomMap(90, 50, 3);
  ASSERT_TRUE(map.has_holistic());
  const FeatureSet query = QueryLike(map, 17);
  const std::vector<float> d = HolisticDistances(query, map, 2, nullptr);
  ASSERT_EQ(d.size(), 90u);
  for (int l = 0; l < map.num_images(); ++l) {
    EXPECT_EQ(d[l],
              HolisticDistance(query.holistic.data(), map.holistic_of(l), map.holistic_grid, 2))
        << "image " << l;
  }
  EXPECT_LT(d[17], 1e-12f);  // 0 up to the rounding of the bytes the map holds
}

// A thread pool gives the very same distances as one thread.
TEST(HolisticSimilarityTest, PoolGivesTheSameDistances) {
  const Map map = test::MakeRandomMap(150, 40, 4);
  const FeatureSet query = QueryLike(map, 99);
  ThreadPool pool(3);
  EXPECT_EQ(HolisticDistances(query, map, 1, &pool), HolisticDistances(query, map, 1, nullptr));
}

// A shift wider than the grid is clamped to cols - 1 rather than read out of bounds.
TEST(HolisticSimilarityTest, ClampsTheShiftToTheGrid) {
  const Map map = test::MakeRandomMap(5, 10, 5);
  const FeatureSet query = QueryLike(map, 2);
  const int widest = map.holistic_grid.cols - 1;
  EXPECT_EQ(HolisticDistances(query, map, 1000, nullptr),
            HolisticDistances(query, map, widest, nullptr));
}

// No distances when the query or the map has no holistic descriptor.
TEST(HolisticSimilarityTest, EmptyWithoutDescriptors) {
  Map map = test::MakeRandomMap(5, 10, 6);
  EXPECT_TRUE(HolisticDistances(FeatureSet(), map, 2, nullptr).empty());
  const FeatureSet query = QueryLike(map, 1);
  map.holistic_grid = HolisticGrid();
  map.holistic.clear();
  EXPECT_TRUE(HolisticDistances(query, map, 2, nullptr).empty());
}

}  // namespace
}  // namespace sceneloc
