#include "common/matching/verification.h"

#include <opencv2/calib3d.hpp>

namespace sceneloc {

int CountEpipolarInliers(const FeatureSet& features, const Map& map, int location,
                         const std::vector<float>& best_score,
                         const std::vector<int32_t>& best_feature, double ransac_threshold_px,
                         int max_iterations) {
  std::vector<cv::Point2f> query, tour;
  for (uint32_t k = map.image_offsets[location]; k < map.image_offsets[location + 1]; ++k) {
    const uint32_t g = map.image_landmarks[k];
    if (best_feature[g] < 0 || best_score[g] <= 0) continue;
    for (uint32_t o = map.observation_offsets[g]; o < map.observation_offsets[g + 1]; ++o) {
      if (map.observation_image[o] != static_cast<uint32_t>(location)) continue;
      const Keypoint& kp = features.keypoints[static_cast<size_t>(best_feature[g])];
      query.emplace_back(kp.x, kp.y);
      tour.emplace_back(map.observation_x[o], map.observation_y[o]);
      break;
    }
  }
  if (query.size() < 8) return 0;
  try {
    cv::Mat inliers;
    // A fixed RNG state keeps answers repeatable: OpenCV's RANSAC draws from theRNG().
    cv::theRNG().state = 0x12345678;
    const cv::Mat f = cv::findFundamentalMat(query, tour, cv::FM_RANSAC, ransac_threshold_px, 0.99,
                                             max_iterations, inliers);
    if (f.empty() || inliers.empty()) return 0;
    return cv::countNonZero(inliers);
  } catch (const cv::Exception&) {
    return 0;  // degenerate point sets: no geometric support
  }
}

}  // namespace sceneloc
