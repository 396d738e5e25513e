// Geometric verification of a candidate location (common/matching/verification.h): which
// matched landmarks become correspondences, RANSAC inliers of a true two-view geometry
// against random ones, the median scale ratio, and the orientation check.
#include "common/matching/verification.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>
#include <thread>

#include "tests/support/two_view.h"

namespace sceneloc {
namespace {

// A tour of two images whose every landmark g is seen in both, and a query whose feature g
// is that landmark: where the query sees it, where image 0 saw it (the two views of
// TwoViewPoints), and at `size_ratio` times its size in image 0. Image 1 sees each
// landmark elsewhere. Landmarks from `first_random` on are seen by the query at random
// places (outliers).
struct Scene {
  FeatureSet query;
  Map map;
  std::vector<float> best_score;
  std::vector<int32_t> best_feature;
};

Scene MakeScene(int landmarks, int first_random, float size_ratio, uint32_t seed) {
  const std::vector<test::PointPair> pairs = test::TwoViewPoints(landmarks, seed);
  std::mt19937 rng(seed + 1);
  std::uniform_real_distribution<float> x(0, 480), y(0, 270);
  Scene s;
  s.query.image_width = 480;
  s.query.image_height = 270;
  s.map.image_names = {"a.jpg", "b.jpg"};
  s.map.observation_offsets = {0};
  for (int g = 0; g < landmarks; ++g) {
    const test::PointPair& p = pairs[g];
    const bool outlier = g >= first_random;
    const float tour_size = 2.0f + 0.1f * static_cast<float>(g % 7);
    s.query.keypoints.push_back(
        {outlier ? x(rng) : p.x1, outlier ? y(rng) : p.y1, tour_size * size_ratio, 90, 1, 0});
    for (int image : {0, 1}) {
      s.map.AddObservation(image, image == 0 ? p.x0 : x(rng), image == 0 ? p.y0 : y(rng), tour_size,
                           90);
    }
    s.map.observation_offsets.push_back(static_cast<uint32_t>(s.map.observation_image.size()));
    s.map.image_landmarks.push_back(g);
    s.best_score.push_back(1.0f);
    s.best_feature.push_back(g);
  }
  s.map.image_offsets = {0, static_cast<uint32_t>(landmarks), static_cast<uint32_t>(landmarks)};
  return s;
}

Verification Verify(const Scene& s, VerifyOptions options = {},
                    VerifyEstimator estimator = VerifyEstimator::kUsac) {
  options.estimator = estimator;
  return VerifyCandidate(s.query, s.map, 0, LandmarkScope::Whole(s.map), s.best_score,
                         s.best_feature, options);
}

// Every property holds for both estimators (USAC, the default, and classic RANSAC).
class VerificationTest : public ::testing::TestWithParam<VerifyEstimator> {
 protected:
  Verification Run(const Scene& s, const VerifyOptions& options = {}) const {
    return Verify(s, options, GetParam());
  }
};

// A true two-view geometry: every correspondence is an inlier, and the scale is the
// query's size over the tour's.
TEST_P(VerificationTest, TrueGeometryIsAllInliers) {
  const Scene s = MakeScene(40, 40, 1.5f, 3);
  const Verification v = Run(s);
  EXPECT_EQ(v.correspondences, 40);
  EXPECT_EQ(v.inliers, 40);
  EXPECT_NEAR(v.log_scale, std::log(1.5f), 1e-5);
}

// Random correspondences mixed in are mostly rejected; the true ones stay inliers.
TEST_P(VerificationTest, RandomCorrespondencesAreRejected) {
  const Scene s = MakeScene(60, 45, 1.0f, 4);
  const Verification v = Run(s);
  EXPECT_EQ(v.correspondences, 60);
  EXPECT_GE(v.inliers, 45);
  EXPECT_LE(v.inliers, 50);
  EXPECT_NEAR(v.log_scale, 0.0f, 1e-5);
}

// Only landmarks the query matched (a best feature and a positive score) count; with
// fewer than 8 correspondences there is no RANSAC and no inlier.
TEST_P(VerificationTest, OnlyMatchedLandmarksCount) {
  Scene s = MakeScene(20, 20, 1.0f, 5);
  for (int g = 0; g < 20; g += 2) s.best_feature[g] = -1;
  s.best_score[1] = 0;
  EXPECT_EQ(Run(s).correspondences, 9);
  for (int g = 1; g < 20; g += 4) s.best_score[g] = 0;
  const Verification few = Run(s);
  EXPECT_EQ(few.correspondences, 5);
  EXPECT_EQ(few.inliers, 0);
}

// With an orientation tolerance, a correspondence whose orientations differ by more is
// dropped; the difference is taken around the circle (355 and 5 degrees are 10 apart).
TEST_P(VerificationTest, OrientationCheckDropsTurnedMatches) {
  Scene s = MakeScene(30, 30, 1.0f, 6);
  for (int g = 0; g < 10; ++g) s.query.keypoints[g].angle = 180;
  for (int g = 10; g < 20; ++g) {
    s.query.keypoints[g].angle = 355;
    s.map.observations[2 * g].angle = PackObservation(0, 0, 1, 5).angle;
  }
  VerifyOptions options;
  EXPECT_EQ(Run(s, options).correspondences, 30);  // no check by default
  options.angle_tolerance_deg = 20;
  EXPECT_EQ(Run(s, options).correspondences, 20);
  s.map.observation_angles = false;  // a map without orientations is not checked
  EXPECT_EQ(Run(s, options).correspondences, 30);
}

// A query taken where the tour camera stood sees every point where the tour saw it (the
// points are related by a homography, degenerate for a fundamental matrix): every
// correspondence still counts as an inlier.
TEST_P(VerificationTest, TheTourCamerasOwnViewpointVerifies) {
  Scene s = MakeScene(30, 30, 1.0f, 8);
  for (int g = 0; g < 30; ++g) {
    s.query.keypoints[g].x = s.map.ObservationX(2 * g);
    s.query.keypoints[g].y = s.map.ObservationY(2 * g);
  }
  const Verification v = Run(s);
  EXPECT_EQ(v.correspondences, 30);
  EXPECT_EQ(v.inliers, 30);
}

// The same input gives the same answer, on any thread (each call seeds its own state).
TEST_P(VerificationTest, Deterministic) {
  const Scene s = MakeScene(50, 20, 1.2f, 7);
  const Verification a = Run(s);
  Verification b;
  std::thread other([&] { b = Run(s); });  // and on another thread
  other.join();
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.log_scale, b.log_scale);
}

// Both estimators find the same inliers where the geometry is clear (true and random
// correspondences mixed), so switching between them does not change what an inlier means.
TEST(VerificationEstimatorsTest, AgreeOnAClearScene) {
  for (uint32_t seed = 10; seed < 15; ++seed) {
    const Scene s = MakeScene(80, 50, 1.1f, seed);
    const Verification usac = Verify(s, {}, VerifyEstimator::kUsac);
    const Verification ransac = Verify(s, {}, VerifyEstimator::kRansac);
    EXPECT_GE(usac.inliers, 50) << seed;
    EXPECT_LE(std::abs(usac.inliers - ransac.inliers), 3) << seed;
    EXPECT_NEAR(usac.log_scale, ransac.log_scale, 1e-5) << seed;
  }
}

INSTANTIATE_TEST_SUITE_P(Estimators, VerificationTest,
                         ::testing::Values(VerifyEstimator::kUsac, VerifyEstimator::kRansac),
                         [](const ::testing::TestParamInfo<VerifyEstimator>& info) {
                           return info.param == VerifyEstimator::kUsac ? "Usac" : "Ransac";
                         });

}  // namespace
}  // namespace sceneloc
