#include "common/matching/confidence.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

constexpr double kT = 0.2;        // the default temperature
constexpr double kPlateau = 2.0;  // the default plateau (MatchOptions::confidence_plateau)

// A clear winner with its neighbours close behind: nearly all mass within the tolerance.
TEST(ConfidenceTest, ClearWinnerWithNeighbours) {
  std::vector<float> s(100, 0.0f);
  s[40] = 6.0f;
  s[39] = s[41] = 4.5f;
  EXPECT_GT(LocationPosterior(s, 40, 2, kT, kPlateau), 0.99);
}

// Two distant places with the same evidence share the mass: about one half each.
TEST(ConfidenceTest, TwoDistantRivalsHalveIt) {
  std::vector<float> s(100, 0.0f);
  s[10] = s[70] = 5.0f;
  EXPECT_NEAR(LocationPosterior(s, 10, 2, kT, kPlateau), 0.5, 0.01);
  s[70] = 4.0f;  // a weaker rival: the answer keeps more
  const double p = LocationPosterior(s, 10, 2, kT, kPlateau);
  EXPECT_GT(p, 0.9);
  EXPECT_LT(p, 1.0);
}

// Rivals only among the adjacent frames are no rivals: they lie within the tolerance.
TEST(ConfidenceTest, AdjacentFramesAreNotRivals) {
  std::vector<float> s(100, 0.0f);
  s[50] = s[51] = s[52] = 5.0f;
  EXPECT_GT(LocationPosterior(s, 51, 2, kT, kPlateau), 0.99);
  EXPECT_NEAR(LocationPosterior(s, 51, 0, kT, kPlateau), 1.0 / 3.0, 0.01);  // tolerance 0: they are
}

// Nothing matched: no evidence tells any location from another, so no confidence; a single
// location with a little evidence gets little more than its window's share.
TEST(ConfidenceTest, NothingMatchedIsZero) {
  std::vector<float> s(100, 0.0f);
  EXPECT_EQ(LocationPosterior(s, 50, 2, kT, kPlateau), 0.0);
  EXPECT_EQ(LocationPosterior({}, 0, 2, kT, kPlateau), 0.0);
  s[50] = 0.01f;
  EXPECT_NEAR(LocationPosterior(s, 50, 2, kT, kPlateau), 5.0 / 100.0, 0.01);
  EXPECT_NEAR(LocationPosterior(s, 0, 2, kT, kPlateau), 3.0 / 100.0,
              0.01);  // the tour's first frame
}

// Evidence that rises evenly over a few frames and peaks one frame past the tolerance of
// the truth (Gardens Point day query 40, answered 37: scores 8.8, 8.0, 7.6 at 37-39, 6.7 and
// 6.8 at 40-41): one temperature reads the small steps between neighbours as certainty;
// the plateau reading leaves room for the truth beyond the tolerance.
TEST(ConfidenceTest, APlateauPastTheToleranceLowersIt) {
  constexpr double kT = 0.28;  // the temperature these scores were read at when measured
  std::vector<float> s(100, 0.0f);
  s[37] = 8.77f;
  s[38] = 7.97f;
  s[39] = 7.55f;
  s[40] = 6.73f;
  s[41] = 6.82f;
  const double one = LocationPosterior(s, 37, 2, kT, 1.0);
  const double flat = LocationPosterior(s, 37, 2, kT, kPlateau);
  EXPECT_GT(one, 0.99);
  EXPECT_LT(flat, one - 0.01);
  EXPECT_LT(LocationPosterior(s, 37, 2, kT, 4.0), flat);  // flatter still: lower still
  // By hand: offsets 0-3 read at 2T, offset 4 and beyond at T.
  double near = 0, total = 0;
  for (int l = 0; l < 100; ++l) {
    const int offset = std::abs(l - 37);
    const double w = std::exp((s[l] - s[37]) / (offset <= 3 ? kPlateau * kT : kT));
    total += w;
    if (offset <= 2) near += w;
  }
  EXPECT_NEAR(flat, near / total, 1e-6);
}

// The plateau changes nothing about distant rivals, nor about a lone peak: plateau 1 is the
// single-temperature posterior.
TEST(ConfidenceTest, ThePlateauLeavesDistantRivalsAlone) {
  std::vector<float> s(100, 0.0f);
  s[10] = s[70] = 5.0f;
  EXPECT_NEAR(LocationPosterior(s, 10, 2, kT, kPlateau), 0.5, 0.01);
  EXPECT_NEAR(LocationPosterior(s, 10, 2, kT, kPlateau), LocationPosterior(s, 10, 2, kT, 1.0),
              0.001);
  s[70] = 4.0f;
  double total = 0;
  for (float v : s) total += std::exp((v - 5.0) / kT);
  EXPECT_NEAR(LocationPosterior(s, 10, 2, kT, 1.0), 1.0 / total * (1 + 4 * std::exp(-5 / kT)),
              1e-6);
}

// Large scores do not overflow.
TEST(ConfidenceTest, LargeScoresStayFinite) {
  std::vector<float> s(10, 1000.0f);
  s[3] = 1200.0f;
  EXPECT_NEAR(LocationPosterior(s, 3, 0, kT, kPlateau), 1.0, 1e-9);
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

// A twin known to the map (a look-alike at ratio 0.9) is read at a tenth of the evidence
// difference: the answer that would be sure of itself against a distinct place of the same
// evidence shares its mass with the twin; a look-alike at ratio 0 changes nothing.
TEST(ConfidenceTest, ALookAlikeIsReadAsWeakerEvidence) {
  Map map;
  map.image_names.resize(100);
  map.options.tolerance = 2;
  map.lookalike_offsets.assign(101, 0);
  // 40 has one look-alike, 80, at 0.9; every other location none.
  map.lookalike_location = {80};
  map.lookalike_ratio = {0.9f};
  for (size_t l = 41; l < map.lookalike_offsets.size(); ++l) map.lookalike_offsets[l] = 1;
  ASSERT_TRUE(map.has_lookalikes());
  const LocationTemperatures own = LookAlikeTemperatures(map, 40, kT);
  ASSERT_EQ(own.size(), 5u);  // 78..82
  EXPECT_EQ(own.front().first, 78);
  EXPECT_NEAR(own.front().second, kT / (1 - 0.9), 1e-5);  // the ratio is a float
  EXPECT_TRUE(LookAlikeTemperatures(map, 41, kT).empty());

  std::vector<float> s(100, 0.0f);
  s[40] = 6.0f;
  s[80] = 4.0f;  // two units below: decisive between distinct places
  const double distinct = LocationPosterior(s, 40, 2, kT, kPlateau);
  const double twin = LocationPosterior(s, 40, 2, kT, kPlateau, own);
  EXPECT_GT(distinct, 0.99);
  // The twin and the four locations about it, each at ten times the temperature.
  const double t = kT / (1 - 0.9);
  EXPECT_NEAR(twin, 1 / (1 + std::exp(-2.0 / t) + 4 * std::exp(-6.0 / t)), 1e-3);
  EXPECT_LT(twin, 0.7);

  map.lookalike_ratio = {0.0f};  // stored ratios are > 0; 0 reads as no look-alike
  EXPECT_NEAR(LocationPosterior(s, 40, 2, kT, kPlateau, LookAlikeTemperatures(map, 40, kT)),
              distinct, 1e-12);
}

// Ratios above kMaxLookAlikeRatio read as it: a place is never quite its look-alike.
TEST(ConfidenceTest, ALookAlikeRatioIsCapped) {
  Map map;
  map.image_names.resize(20);
  map.lookalike_offsets.assign(21, 1);
  map.lookalike_offsets[0] = 0;
  map.lookalike_location = {15};
  map.lookalike_ratio = {1.0f};
  const LocationTemperatures own = LookAlikeTemperatures(map, 0, kT);
  ASSERT_FALSE(own.empty());
  EXPECT_NEAR(own.front().second, kT / (1 - kMaxLookAlikeRatio), 1e-9);
}

}  // namespace
}  // namespace sceneloc
