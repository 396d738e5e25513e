// Geometric verification of the best candidate locations (a departure from the paper,
// measured in docs/results.md): for a candidate tour image l, each landmark of G_l that
// the query matched gives a correspondence between its best query feature and where the
// landmark was seen in l. Two cues say whether the query views the scene from l:
//   - how many correspondences are inliers of a RANSAC fundamental matrix, and
//   - the median log ratio of query to tour keypoint size over those inliers: a tour
//     image taken further back along the route sees the same points smaller, so at the
//     true location the ratio is near 1 (log near 0).
#pragma once

#include <cstdint>
#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/matching/landmark_scope.h"

namespace sceneloc {

struct Verification {
  int correspondences = 0;  // matched landmarks of the candidate seen in its image
  int inliers = 0;          // epipolar inliers; 0 with fewer than 8 correspondences
  float log_scale = 0;      // median log(query size / tour size) over the inliers
};

// How the fundamental matrix is searched for. Both maximise the number of correspondences
// within the threshold of a 7-point hypothesis, with at most max_iterations hypotheses.
enum class VerifyEstimator {
  // OpenCV's USAC framework, configured as plain RANSAC (inlier count, uniform sampling, no
  // local optimisation) but with its SPRT test, which drops a wrong hypothesis after a few
  // points instead of scoring all of them, and its DEGENSAC check of planar samples. About a
  // ninth of kRansac's time; match rates and PR-AUC the same within RANSAC's own sampling
  // noise, recall at 100% precision lower on average (docs/results.md, "Verification").
  kUsac,
  // OpenCV's classic FM_RANSAC (cv::findFundamentalMat).
  kRansac,
};

struct VerifyOptions {
  double ransac_threshold_px = 3.0;  // epipolar inlier distance, pixels of the map frame
  int max_iterations = 200;          // RANSAC iterations at most
  VerifyEstimator estimator = VerifyEstimator::kUsac;
  // A correspondence whose query and tour keypoint orientations differ by more than this is
  // dropped before RANSAC (an upright camera does not roll between visits, so a true match
  // keeps its orientation). 0 = no orientation check; maps without orientations have none.
  double angle_tolerance_deg = 0;
};

// best_score[p] and best_feature[p] are max_f S(f, g) and its argmax (-1 when g matched
// nothing) of the landmark g at scope position p; landmarks outside the scope matched
// nothing. Deterministic for the same input.
Verification VerifyCandidate(const FeatureSet& features, const Map& map, int location,
                             const LandmarkScope& scope, const std::vector<float>& best_score,
                             const std::vector<int32_t>& best_feature,
                             const VerifyOptions& options);

}  // namespace sceneloc
