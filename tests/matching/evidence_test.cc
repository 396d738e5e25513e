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

// A candidate at `location` with holistic z-score `z`, `inliers` inliers and log scale `m`.
CandidateEvidence Candidate(int location, float z, int inliers, float m) {
  CandidateEvidence c;
  c.location = location;
  c.holistic = 0.1f;
  c.holistic_z = z;
  c.inliers = inliers;
  c.log_scale = m;
  return c;
}

// Evidence along a 60-location route: the answer at 20 whose inliers agree with the camera,
// its neighbours, and a rival 6 frames on whose inliers are 0.25 larger than the camera's.
struct Route {
  std::vector<CandidateEvidence> candidates;
  std::vector<float> holistic_z;
  MatchOptions options;
  std::vector<float> Scores() const {
    return LocationScores(candidates, holistic_z, holistic_z.size(), options);
  }
};

Route RivalRoute(int rival_inliers) {
  Route r;
  r.holistic_z.assign(60, 0.0f);
  for (int l = 0; l < 60; ++l) r.holistic_z[l] = 0.05f * static_cast<float>(l % 7);
  r.candidates = {Candidate(20, 2.0f, 40, 0.0f), Candidate(21, 1.8f, 30, 0.05f),
                  Candidate(19, 1.5f, 25, -0.05f), Candidate(26, 1.9f, rival_inliers, 0.25f),
                  Candidate(45, 0.5f, 9, 0.6f)};
  return r;
}

// The weighted mean of LocationPosterior over the nine cameras, each scored from scratch:
// what CameraAveragedPosterior computes without rescoring the other locations.
double BruteForceAverage(const Route& r, int answer, int tolerance, double t) {
  double sum = 0, weights = 0;
  for (int k = -4; k <= 4; ++k) {
    const double x = k / 2.0;
    MatchOptions at = r.options;
    at.camera_log_scale = r.options.camera_log_scale + x * r.options.confidence_scale_spread;
    const std::vector<float> s = LocationScores(r.candidates, r.holistic_z, 60, at);
    sum += std::exp(-x * x / 2) * LocationPosterior(s, answer, tolerance, t, at.confidence_plateau);
    weights += std::exp(-x * x / 2);
  }
  return sum / weights;
}

// Averaging over cameras is the weighted mean of the posterior at each, computed once per
// location; with no spread, or no scale cue, it is the posterior of the camera in use.
TEST(EvidenceTest, CameraAveragedPosteriorIsTheMeanOverCameras) {
  for (const double camera : {0.0, 0.2, -0.3}) {
    for (const double spread : {0.05, 0.1, 0.3}) {
      Route r = RivalRoute(60);
      r.options.camera_log_scale = camera;
      r.options.confidence_scale_spread = spread;
      for (const int answer : {20, 26, 45}) {
        const double fast =
            CameraAveragedPosterior(r.Scores(), r.candidates, answer, 2, 0.2, r.options);
        EXPECT_NEAR(fast, BruteForceAverage(r, answer, 2, 0.2), 1e-6)
            << "camera " << camera << " spread " << spread << " answer " << answer;
      }
    }
  }
  Route r = RivalRoute(60);
  const std::vector<float> s = r.Scores();
  r.options.confidence_scale_spread = 0;
  EXPECT_EQ(CameraAveragedPosterior(s, r.candidates, 20, 2, 0.2, r.options),
            LocationPosterior(s, 20, 2, 0.2, r.options.confidence_plateau));
  r.options.confidence_scale_spread = 0.1;
  r.options.verify_scale_sigma = 0;
  EXPECT_EQ(CameraAveragedPosterior(r.Scores(), r.candidates, 20, 2, 0.2, r.options),
            LocationPosterior(r.Scores(), 20, 2, 0.2, r.options.confidence_plateau));
  // Nothing tells the locations apart: 0, as LocationPosterior (with candidates, so the
  // average's own check answers, not the fallback to LocationPosterior).
  r.options.verify_scale_sigma = 0.25;
  EXPECT_EQ(
      CameraAveragedPosterior(std::vector<float>(60, 1.0f), r.candidates, 20, 2, 0.2, r.options),
      0.0);
}

// A camera in doubt (a frame whose shape leaves it open: FrameCamera) widens the cameras
// averaged over, the doubt and the spread in quadrature; with the spread turned off there is
// no average, doubt or not.
TEST(EvidenceTest, CameraDoubtWidensTheAverage) {
  Route doubted = RivalRoute(52);
  doubted.options.confidence_scale_spread = 0.1;
  doubted.options.camera_log_doubt = 0.144;
  Route wide = RivalRoute(52);
  wide.options.confidence_scale_spread = std::hypot(0.1, 0.144);
  Route sure = RivalRoute(52);
  sure.options.confidence_scale_spread = 0.1;
  const std::vector<float> s = sure.Scores();
  const double with_doubt =
      CameraAveragedPosterior(s, doubted.candidates, 20, 2, 0.2, doubted.options);
  EXPECT_NEAR(with_doubt, CameraAveragedPosterior(s, wide.candidates, 20, 2, 0.2, wide.options),
              1e-12);
  EXPECT_LT(with_doubt,
            CameraAveragedPosterior(s, sure.candidates, 20, 2, 0.2, sure.options) - 0.02);
  doubted.options.confidence_scale_spread = 0;
  EXPECT_EQ(CameraAveragedPosterior(s, doubted.candidates, 20, 2, 0.2, doubted.options),
            LocationPosterior(s, 20, 2, 0.2, doubted.options.confidence_plateau));
}

// An answer that wins only for exactly the camera in use is less certain over cameras; one
// that wins for any camera nearby is not; the average is centred on the camera in use.
TEST(EvidenceTest, CameraAveragedPosteriorDoubtsAnswersOfOneCamera) {
  Route close = RivalRoute(52);  // at camera 0 the answer leads; at +0.1 the rival would
  const std::vector<float> s = close.Scores();
  const double alone = LocationPosterior(s, 20, 2, 0.2, close.options.confidence_plateau);
  const double averaged = CameraAveragedPosterior(s, close.candidates, 20, 2, 0.2, close.options);
  EXPECT_GT(alone, 0.9);
  EXPECT_LT(averaged, alone - 0.1);
  Route clear = RivalRoute(12);  // the rival barely above chance whatever the camera
  EXPECT_NEAR(CameraAveragedPosterior(clear.Scores(), clear.candidates, 20, 2, 0.2, clear.options),
              LocationPosterior(clear.Scores(), 20, 2, 0.2, clear.options.confidence_plateau),
              1e-3);
  // A camera stated at the rival's scale: the rival now leads, and the average, centred on
  // that camera, gives the old answer little.
  close.options.camera_log_scale = 0.25;
  const std::vector<float> at_rival = close.Scores();
  EXPECT_GT(at_rival[26], at_rival[20]);
  EXPECT_LT(CameraAveragedPosterior(at_rival, close.candidates, 20, 2, 0.2, close.options), 0.5);
}

}  // namespace
}  // namespace sceneloc
