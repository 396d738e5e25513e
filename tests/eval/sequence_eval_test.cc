#include "tools/eval/sequence_eval.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

// The kidnap order is a permutation of whole runs of nearly equal length, no run directly
// after the one it followed, the same for the same seed.
TEST(KidnapOrderTest, ShuffledRunsWithoutNeighbours) {
  const std::vector<int> order = KidnapOrder(100, 5, 3);
  ASSERT_EQ(order.size(), 100u);
  EXPECT_EQ(std::set<int>(order.begin(), order.end()).size(), 100u);
  int jumps = 0;
  for (size_t k = 1; k < order.size(); ++k) {
    if (order[k] != order[k - 1] + 1) {
      ++jumps;
      EXPECT_EQ(order[k] % 20, 0) << "a run starts at a segment boundary";
      EXPECT_NE(order[k], order[k - 1] + 1);
    }
  }
  EXPECT_EQ(jumps, 4);
  EXPECT_EQ(order, KidnapOrder(100, 5, 3));
  EXPECT_NE(order, KidnapOrder(100, 5, 4));
  const std::vector<int> file_order = KidnapOrder(10, 1, 3);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(file_order[i], i);
}

// Reversed (--reverse): the same order walked backwards, with or without a kidnap.
TEST(KidnapOrderTest, Reversed) {
  const std::vector<int> backwards = KidnapOrder(10, 1, 3, true);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(backwards[i], 9 - i);
  std::vector<int> kidnap = KidnapOrder(100, 5, 3);
  std::reverse(kidnap.begin(), kidnap.end());
  EXPECT_EQ(KidnapOrder(100, 5, 3, true), kidnap);
}

// A session over synthetic single-frame outcomes: the filtered answers replace ours, and a
// kidnap's jumps are each counted with the frames it took to be right again.
TEST(RunSequenceTest, FiltersAndCountsRelocalisation) {
  const Map map = test::MakeRandomMap(60, 200, 5);
  std::vector<QueryOutcome> outcomes(60);
  for (int q = 0; q < 60; ++q) {
    outcomes[q].truth = q;
    outcomes[q].in_map = 0.95;
    outcomes[q].location_scores.resize(60);
    for (int l = 0; l < 60; ++l) {
      const double d = l - q;
      outcomes[q].location_scores[l] = static_cast<float>(4 * std::exp(-d * d / 2));
    }
    // Every fifth frame alone points 30 locations away.
    if (q % 5 == 4) outcomes[q].location_scores[(q + 30) % 60] = 6;
    outcomes[q].ours.predicted = q % 5 == 4 ? (q + 30) % 60 : q;
  }
  SequenceOptions options;
  const SequenceRun in_order = RunSequence(outcomes, map, options, KidnapOrder(60, 1, 1));
  ASSERT_EQ(in_order.filtered.size(), 60u);
  int right = 0;
  for (int q = 0; q < 60; ++q) right += std::abs(in_order.filtered[q].ours.predicted - q) <= 2;
  EXPECT_GE(right, 57);  // the fooled single frames are put right
  EXPECT_TRUE(in_order.relocalisation.to_correct.empty());
  const SequenceRun kidnap = RunSequence(outcomes, map, options, KidnapOrder(60, 4, 2));
  ASSERT_EQ(kidnap.relocalisation.to_correct.size(), 3u);
  ASSERT_EQ(kidnap.relocalisation.to_localised.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(kidnap.relocalisation.to_correct[i], kidnap.relocalisation.to_localised[i]);
    EXPECT_LE(kidnap.relocalisation.to_localised[i], 5);
  }
  // Backing up the route: every step a neighbour (no jump), followed as well as walking on;
  // and the reversed kidnap has the same three jumps.
  const SequenceRun backwards = RunSequence(outcomes, map, options, KidnapOrder(60, 1, 1, true));
  right = 0;
  for (int q = 0; q < 60; ++q) right += std::abs(backwards.filtered[q].ours.predicted - q) <= 2;
  EXPECT_GE(right, 57);
  EXPECT_TRUE(backwards.relocalisation.to_correct.empty());
  const SequenceRun reversed_kidnap =
      RunSequence(outcomes, map, options, KidnapOrder(60, 4, 2, true));
  EXPECT_EQ(reversed_kidnap.relocalisation.to_correct.size(), 3u);
}

}  // namespace
}  // namespace sceneloc
