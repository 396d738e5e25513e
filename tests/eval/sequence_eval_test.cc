#include "tools/eval/sequence_eval.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

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

// Single-frame outcomes of 60 queries of a 60-location route, query q at location q: a
// peak there, except that every `fooled`-th frame alone points 30 locations away (0: none
// fooled) and, with `truth_offset`, the truth is that far from the evidence.
std::vector<QueryOutcome> SyntheticOutcomes(int fooled = 5, int truth_offset = 0) {
  std::vector<QueryOutcome> outcomes(60);
  for (int q = 0; q < 60; ++q) {
    outcomes[q].truth = (q + truth_offset) % 60;
    outcomes[q].in_map = 0.95;
    outcomes[q].location_scores.resize(60);
    for (int l = 0; l < 60; ++l) {
      const double d = l - q;
      outcomes[q].location_scores[l] = static_cast<float>(4 * std::exp(-d * d / 2));
    }
    const bool is_fooled = fooled > 0 && q % fooled == fooled - 1;
    if (is_fooled) outcomes[q].location_scores[(q + 30) % 60] = 6;
    outcomes[q].ours.predicted = is_fooled ? (q + 30) % 60 : q;
  }
  return outcomes;
}

// A session over synthetic single-frame outcomes: the filtered answers replace ours, and a
// kidnap's jumps are each counted with the frames it took to be right again.
TEST(RunSequenceTest, FiltersAndCountsRelocalisation) {
  const Map map = test::MakeRandomMap(60, 200, 5);
  const std::vector<QueryOutcome> outcomes = SyntheticOutcomes();
  MatchOptions options;
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

// The suite's walks over 10 queries, step by step.
TEST(StandardWalksTest, Orders) {
  std::map<std::string, std::vector<int>> walks;
  for (const Walk& w : StandardWalks(10)) {
    EXPECT_FALSE(w.description.empty());
    walks[w.name] = w.order;
  }
  ASSERT_EQ(walks.size(), 8u);
  EXPECT_EQ(walks["in_order"], (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(walks["reversed"], (std::vector<int>{9, 8, 7, 6, 5, 4, 3, 2, 1, 0}));
  EXPECT_EQ(walks["there_and_back"],
            (std::vector<int>{0, 1, 2, 3, 4, 5, 4, 3, 3, 4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(walks["pace_2"], (std::vector<int>{0, 2, 4, 6, 8}));
  EXPECT_EQ(walks["pace_3"], (std::vector<int>{0, 3, 6, 9}));
  ASSERT_EQ(walks["slow_3"].size(), 30u);
  EXPECT_EQ(walks["slow_3"][29], 9);
  EXPECT_EQ(walks["slow_3"][3], 1);
  EXPECT_EQ(walks["stop_10"],
            (std::vector<int>{0, 1, 2, 3, 4, 5, 5, 5, 5, 5, 5, 5, 5, 5, 5, 6, 7, 8, 9}));
  // Speeding up from the tour's pace: 1, 1.19, 1.40, 1.65, 1.91, 2.18 locations a frame.
  EXPECT_EQ(walks["pace_varying"], (std::vector<int>{0, 1, 2, 4, 5, 7, 9}));
  EXPECT_EQ(StandardWalks(1)[0].order, std::vector<int>{0});
}

// Over a longer route the varying pace runs its whole cycle: never backwards, at most three
// locations a frame, standing on one query for a few frames where it is slowest, to the end.
TEST(StandardWalksTest, VaryingPaceRunsItsCycle) {
  std::vector<int> order;
  for (const Walk& w : StandardWalks(100)) {
    if (w.name == "pace_varying") order = w.order;
  }
  ASSERT_FALSE(order.empty());
  EXPECT_EQ(order.front(), 0);
  EXPECT_EQ(order.back(), 99);
  int repeats = 0, fastest = 0;
  for (size_t i = 1; i < order.size(); ++i) {
    const int step = order[i] - order[i - 1];
    EXPECT_GE(step, 0) << i;
    repeats += step == 0 ? 1 : 0;
    fastest = std::max(fastest, step);
  }
  EXPECT_EQ(fastest, 3);
  EXPECT_GE(repeats, 5);
  EXPECT_EQ(order.size(), 66u);  // 100 queries in 66 frames: faster than the tour on average
}

// Every walk over evidence that points at the truth, with every fifth frame fooled, is
// followed; over evidence 10 locations from the truth nothing is right, and what the session
// LOCALISES is counted wrong.
TEST(SummariseWalkTest, RatesPrecisionAndCalibration) {
  const Map map = test::MakeRandomMap(60, 200, 5);
  const MatchOptions options;
  for (const Walk& walk : StandardWalks(60)) {
    SCOPED_TRACE(walk.name);
    const WalkSummary s = SummariseWalk(walk, SyntheticOutcomes(), map, options);
    EXPECT_EQ(s.name, walk.name);
    EXPECT_EQ(s.steps, static_cast<int>(walk.order.size()));
    EXPECT_GE(s.rate, 0.9);
    EXPECT_GT(s.localised, 0);
    EXPECT_GE(s.localised_precision, 0.95);
    // A pace that changes every frame leaves the session less sure than it is right (its
    // LOCALISED answers all right, ECE 0.20 against a floor of 0.11 on 45 frames).
    EXPECT_LE(s.ece, walk.name == "pace_varying" ? 0.25 : 0.2);
    const WalkSummary off = SummariseWalk(walk, SyntheticOutcomes(0, 10), map, options);
    EXPECT_EQ(off.rate, 0);
    EXPECT_GT(off.localised, 0);
    EXPECT_EQ(off.localised_precision, 0);
    EXPECT_GE(off.ece, 0.5);  // sure of wrong answers
  }
}

// The kidnapped robot over seeds: every jump of every seed counted, each found again soon.
TEST(SummariseKidnapsTest, EveryJumpOfEverySeed) {
  const Map map = test::MakeRandomMap(60, 200, 5);
  const KidnapSummary k = SummariseKidnaps(SyntheticOutcomes(), map, MatchOptions(), 4, 3);
  EXPECT_EQ(k.segments, 4);
  EXPECT_EQ(k.seeds, 3);
  EXPECT_EQ(k.jumps, 9);
  EXPECT_LE(k.median, 2);
  EXPECT_LE(k.worst, 5);
  EXPECT_GE(k.worst, k.median);
  const KidnapSummary lost = SummariseKidnaps(SyntheticOutcomes(0, 10), map, MatchOptions(), 4, 3);
  EXPECT_EQ(lost.median, 15);  // never right: each segment's whole length
}

}  // namespace
}  // namespace sceneloc
