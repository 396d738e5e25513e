#include "common/matching/confidence.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

constexpr double kT = 0.31;  // the default temperature

// A clear winner with its neighbours close behind: nearly all mass within the tolerance.
TEST(ConfidenceTest, ClearWinnerWithNeighbours) {
  std::vector<float> s(100, 0.0f);
  s[40] = 6.0f;
  s[39] = s[41] = 4.5f;
  EXPECT_GT(LocationPosterior(s, 40, 2, kT), 0.99);
}

// Two distant places with the same evidence share the mass: about one half each.
TEST(ConfidenceTest, TwoDistantRivalsHalveIt) {
  std::vector<float> s(100, 0.0f);
  s[10] = s[70] = 5.0f;
  EXPECT_NEAR(LocationPosterior(s, 10, 2, kT), 0.5, 0.01);
  s[70] = 4.0f;  // a weaker rival: the answer keeps more
  const double p = LocationPosterior(s, 10, 2, kT);
  EXPECT_GT(p, 0.9);
  EXPECT_LT(p, 1.0);
}

// Rivals only among the adjacent frames are no rivals: they lie within the tolerance.
TEST(ConfidenceTest, AdjacentFramesAreNotRivals) {
  std::vector<float> s(100, 0.0f);
  s[50] = s[51] = s[52] = 5.0f;
  EXPECT_GT(LocationPosterior(s, 51, 2, kT), 0.99);
  EXPECT_NEAR(LocationPosterior(s, 51, 0, kT), 1.0 / 3.0, 0.01);  // tolerance 0: they are
}

// Nothing matched: no evidence tells any location from another, so no confidence; a single
// location with a little evidence gets little more than its window's share.
TEST(ConfidenceTest, NothingMatchedIsZero) {
  std::vector<float> s(100, 0.0f);
  EXPECT_EQ(LocationPosterior(s, 50, 2, kT), 0.0);
  EXPECT_EQ(LocationPosterior({}, 0, 2, kT), 0.0);
  s[50] = 0.01f;
  EXPECT_NEAR(LocationPosterior(s, 50, 2, kT), 5.0 / 100.0, 0.01);
  EXPECT_NEAR(LocationPosterior(s, 0, 2, kT), 3.0 / 100.0, 0.01);  // the tour's first frame
}

// Large scores do not overflow.
TEST(ConfidenceTest, LargeScoresStayFinite) {
  std::vector<float> s(10, 1000.0f);
  s[3] = 1200.0f;
  EXPECT_NEAR(LocationPosterior(s, 3, 0, kT), 1.0, 1e-9);
}

// The in-map probability falls as the query's nearest tour image gets as far as frames
// that show no place of the route; without calibration or holistic evidence it is 1.
TEST(ConfidenceTest, InMapProbabilityFollowsTheCalibration) {
  Map map = test::MakeRandomMap(5, 20, 1);
  map.calibration = {true, 0.30f, 0.02f, 5};
  const double near = InMapProbability(map, 0.20), level = InMapProbability(map, 0.30),
               far = InMapProbability(map, 0.36);
  EXPECT_GT(near, 0.99);
  EXPECT_NEAR(level, 1 / (1 + std::exp(-map.options.map_evidence_offset)), 1e-6);
  EXPECT_LT(far, 0.05);
  EXPECT_EQ(InMapProbability(map, -1), 1.0);
  map.calibration.valid = false;
  EXPECT_EQ(InMapProbability(map, 0.36), 1.0);
}

// The paper's L1 / (L1 + L2), and the model a map supports.
TEST(ConfidenceTest, PaperModelAndFallback) {
  EXPECT_NEAR(PaperConfidence({0.1f, 0.3f, 0.1f}), 0.75, 1e-6);
  EXPECT_EQ(PaperConfidence({0.0f, 0.0f}), 0.0);
  EXPECT_EQ(PaperConfidence({0.2f}), 1.0);
  Map map = test::MakeRandomMap(5, 20, 1);
  map.calibration.valid = true;
  EXPECT_EQ(SupportedModel(map, ConfidenceModel::kCalibrated), ConfidenceModel::kCalibrated);
  EXPECT_EQ(SupportedModel(map, ConfidenceModel::kPaper), ConfidenceModel::kPaper);
  map.calibration.valid = false;
  EXPECT_EQ(SupportedModel(map, ConfidenceModel::kCalibrated), ConfidenceModel::kPaper);
  EXPECT_EQ(ParseConfidenceModel("paper").value(), ConfidenceModel::kPaper);
  EXPECT_FALSE(ParseConfidenceModel("bayes").ok());
}

}  // namespace
}  // namespace sceneloc
