#include "common/matching/verification.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>

namespace sceneloc {
namespace {

// |a - b| on the circle, degrees in [0, 180].
float AngleDifferenceDeg(float a, float b) {
  const float d = std::fmod(std::fabs(a - b), 360.0f);
  return d > 180.0f ? 360.0f - d : d;
}

}  // namespace

Verification VerifyCandidate(const FeatureSet& features, const Map& map, int location,
                             const LandmarkScope& scope, const std::vector<float>& best_score,
                             const std::vector<int32_t>& best_feature,
                             const VerifyOptions& options) {
  const bool check_angle = options.angle_tolerance_deg > 0 && map.observation_angles;
  std::vector<cv::Point2f> query, tour;
  std::vector<float> log_scale;
  for (uint32_t k = map.image_offsets[location]; k < map.image_offsets[location + 1]; ++k) {
    const uint32_t g = map.image_landmarks[k];
    const int32_t p = scope.Position(g);
    if (p < 0 || best_feature[p] < 0 || best_score[p] <= 0) continue;
    for (uint32_t o = map.observation_offsets[g]; o < map.observation_offsets[g + 1]; ++o) {
      if (map.observation_image[o] != static_cast<uint32_t>(location)) continue;
      const Keypoint& kp = features.keypoints[static_cast<size_t>(best_feature[p])];
      if (check_angle &&
          AngleDifferenceDeg(kp.angle, map.ObservationAngle(o)) > options.angle_tolerance_deg) {
        break;
      }
      query.emplace_back(kp.x, kp.y);
      tour.emplace_back(map.ObservationX(o), map.ObservationY(o));
      log_scale.push_back(std::log(std::max(kp.size, 1e-3f) / map.ObservationSize(o)));
      break;
    }
  }
  Verification v;
  v.correspondences = static_cast<int>(query.size());
  if (query.size() < 8) return v;
  cv::Mat inliers;
  try {
    // Both estimators seed their own random state on every call (USAC from
    // randomGeneratorState, classic RANSAC from a fixed seed inside OpenCV), so the same
    // input gives the same answer on any thread.
    cv::Mat f;
    if (options.estimator == VerifyEstimator::kUsac) {
      cv::UsacParams usac;
      usac.confidence = 0.99;
      usac.maxIterations = options.max_iterations;
      usac.threshold = options.ransac_threshold_px;
      usac.randomGeneratorState = 0;
      usac.sampler = cv::SAMPLING_UNIFORM;
      usac.score = cv::SCORE_METHOD_RANSAC;
      usac.loMethod = cv::LOCAL_OPTIM_NULL;
      usac.isParallel = false;
      f = cv::findFundamentalMat(query, tour, inliers, usac);
    }
    // USAC finds no model where every sample is degenerate for F, as when all points lie on
    // one plane or the query stands where the tour camera stood (points related by a
    // homography): strong evidence of the place, which classic RANSAC does count. On the
    // Gardens Point sets this happens to 2-11% of candidates, nearly all with 8-10
    // correspondences, so the fallback costs little.
    if (f.empty()) {
      f = cv::findFundamentalMat(query, tour, cv::FM_RANSAC, options.ransac_threshold_px, 0.99,
                                 options.max_iterations, inliers);
    }
    if (f.empty() || inliers.empty()) return v;
  } catch (const cv::Exception&) {
    return v;  // degenerate point sets: no geometric support
  }
  std::vector<float> inlier_scale;
  for (size_t i = 0; i < log_scale.size(); ++i) {
    if (inliers.at<uchar>(static_cast<int>(i)) != 0) inlier_scale.push_back(log_scale[i]);
  }
  v.inliers = static_cast<int>(inlier_scale.size());
  if (!inlier_scale.empty()) {
    auto mid = inlier_scale.begin() + static_cast<std::ptrdiff_t>(inlier_scale.size() / 2);
    std::nth_element(inlier_scale.begin(), mid, inlier_scale.end());
    v.log_scale = *mid;
  }
  return v;
}

}  // namespace sceneloc
