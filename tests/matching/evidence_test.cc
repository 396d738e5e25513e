#include "common/matching/evidence.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sceneloc {
namespace {

// Robust z-scores: the median scores 0, one MAD below it 1/1.4826.
TEST(EvidenceTest, RobustZ) {
  const std::vector<float> z = RobustZ({1.0f, 2.0f, 3.0f, 4.0f, 5.0f});
  ASSERT_EQ(z.size(), 5u);
  EXPECT_FLOAT_EQ(z[2], 0.0f);
  EXPECT_NEAR(z[1], 1.0 / 1.4826, 1e-5);   // one below the median, MAD 1
  EXPECT_NEAR(z[4], -2.0 / 1.4826, 1e-5);  // far: negative
  EXPECT_TRUE(RobustZ({}).empty());
  for (float v : RobustZ({2.0f, 2.0f, 2.0f})) EXPECT_TRUE(std::isfinite(v));  // MAD 0
}

// The best by L come first, then the best by holistic distance not already in, once each.
TEST(EvidenceTest, SelectsBothKindsOfCandidatesOnce) {
  const std::vector<float> likelihood = {0.1f, 0.9f, 0.5f, 0.0f, 0.3f};
  const std::vector<int> by_likelihood = {1, 2, 4, 0, 3};
  const std::vector<float> holistic = {0.5f, 0.1f, 0.4f, 0.2f, 0.6f};  // best: 1, 3, 2
  const std::vector<float> z = RobustZ(holistic);
  MatchOptions options;
  options.verify_top = 2;
  options.holistic_top = 3;
  const std::vector<CandidateEvidence> c =
      SelectCandidates(by_likelihood, likelihood, holistic, z, options);
  ASSERT_EQ(c.size(), 3u);  // 1, 2 by L; 1 and 2 again and 3 by holistic
  EXPECT_EQ(c[0].location, 1);
  EXPECT_EQ(c[1].location, 2);
  EXPECT_EQ(c[2].location, 3);
  EXPECT_EQ(c[0].holistic_rank, 0);
  EXPECT_EQ(c[2].holistic_rank, 1);
  EXPECT_FLOAT_EQ(c[1].likelihood, 0.5f);
  EXPECT_FLOAT_EQ(c[2].holistic_z, z[3]);
  // Without holistic evidence only the best by L.
  const auto local = SelectCandidates(by_likelihood, likelihood, {}, {}, options);
  ASSERT_EQ(local.size(), 2u);
  EXPECT_EQ(local[1].holistic, -1.0f);
}

// Inliers up to the chance level add nothing; each one above adds verify_weight; a scale
// disagreement discounts them; without holistic evidence the verified score ranks alone.
TEST(EvidenceTest, FusesHolisticAndGeometricEvidence) {
  MatchOptions options;  // chance 8, weight 0.2, scale sigma 0.25
  CandidateEvidence c;
  c.holistic = 0.2f;
  c.holistic_z = 3.0f;
  c.inliers = 8;
  EXPECT_DOUBLE_EQ(FuseEvidence(c, options), 3.0);
  c.inliers = 18;
  EXPECT_NEAR(FuseEvidence(c, options), 3.0 + 0.2 * 10, 1e-9);
  c.log_scale = 0.25f;  // one sigma off: weighted by exp(-1/2)
  EXPECT_NEAR(VerifiedScore(c, options), 18 * std::exp(-0.5), 1e-5);
  c.holistic = -1;  // no holistic descriptor
  EXPECT_NEAR(FuseEvidence(c, options), 18 * std::exp(-0.5), 1e-5);
}

// The scale cue measures agreement from the camera's own scale: a candidate whose sizes are
// the camera's agrees fully, one at the tour camera's is as far off as the camera is.
TEST(EvidenceTest, ScaleCueIsReadFromTheCamerasScale) {
  MatchOptions options;
  CandidateEvidence c;
  c.inliers = 20;
  c.log_scale = 0.3f;
  EXPECT_NEAR(VerifiedScore(c, options), 20 * std::exp(-0.09 / (2 * 0.0625)), 1e-4);
  options.camera_log_scale = 0.3;
  EXPECT_NEAR(VerifiedScore(c, options), 20, 1e-4);
  c.log_scale = 0.0f;
  EXPECT_NEAR(VerifiedScore(c, options), 20 * std::exp(-0.09 / (2 * 0.0625)), 1e-4);
}

// ScoreCandidates rewrites the candidates' entries and leaves every other location's, and
// skips a candidate past the end.
TEST(EvidenceTest, ScoreCandidatesRewritesOnlyTheCandidates) {
  MatchOptions options;
  CandidateEvidence c;
  c.location = 1;
  c.holistic = 0.1f;
  c.holistic_z = 1.0f;
  c.inliers = 28;
  c.log_scale = 0.25f;
  CandidateEvidence past = c;
  past.location = 7;
  std::vector<float> scores = {-1.0f, 0.0f, 2.0f};
  options.camera_log_scale = 0.25;
  ScoreCandidates({c, past}, options, &scores);
  EXPECT_FLOAT_EQ(scores[0], -1.0f);
  EXPECT_NEAR(scores[1], 1.0 + 0.2 * 20, 1e-5);
  EXPECT_FLOAT_EQ(scores[2], 2.0f);
}

// Every location gets a score on the confidence's scale: candidates their fused evidence,
// others their holistic z-score.
TEST(EvidenceTest, LocationScoresCoverEveryLocation) {
  MatchOptions options;
  CandidateEvidence c;
  c.location = 2;
  c.holistic = 0.1f;
  c.holistic_z = 4.0f;
  c.inliers = 13;
  const std::vector<float> z = {0.5f, -1.0f, 4.0f, 0.0f};
  const std::vector<float> s = LocationScores({c}, z, 4, options);
  ASSERT_EQ(s.size(), 4u);
  EXPECT_FLOAT_EQ(s[0], 0.5f);
  EXPECT_FLOAT_EQ(s[1], -1.0f);
  EXPECT_NEAR(s[2], 4.0 + 0.2 * 5, 1e-5);
  options.use_holistic = false;
  const std::vector<float> local = LocationScores({c}, {}, 4, options);
  EXPECT_FLOAT_EQ(local[0], 0.0f);
  EXPECT_NEAR(local[2], 0.2 * 5, 1e-5);
}

}  // namespace
}  // namespace sceneloc
