#include "common/features/feature_set.h"

#include <cmath>
#include <string>

namespace sceneloc {

void NormaliseRows(DescriptorMatrix* m) {
  for (Eigen::Index i = 0; i < m->rows(); ++i) {
    const float norm = m->row(i).norm();
    if (norm > 0) m->row(i) /= norm;
  }
}

Status ValidateFeatureSet(const FeatureSet& f) {
  if (f.image_width <= 0 || f.image_height <= 0) {
    return InvalidArgument("feature set image size must be positive");
  }
  const auto n = static_cast<Eigen::Index>(f.keypoints.size());
  if (f.local.rows() != n || f.context.rows() != n) {
    return InvalidArgument("feature set has " + std::to_string(n) + " keypoints but " +
                           std::to_string(f.local.rows()) + " local and " +
                           std::to_string(f.context.rows()) + " context descriptors");
  }
  if (!f.local.allFinite() || !f.context.allFinite()) {
    return InvalidArgument("feature set descriptors hold a non-finite number");
  }
  for (size_t i = 0; i < f.keypoints.size(); ++i) {
    const Keypoint& k = f.keypoints[i];
    if (!std::isfinite(k.x) || !std::isfinite(k.y) || !std::isfinite(k.size) ||
        !std::isfinite(k.angle)) {
      return InvalidArgument("keypoint " + std::to_string(i) + " holds a non-finite number");
    }
  }
  const HolisticGrid& g = f.holistic_grid;
  if (g.cols < 0 || g.rows < 0 || g.bins < 0 || g.cols > 64 || g.rows > 256 || g.bins > 36) {
    return InvalidArgument("feature set holistic grid is out of range");
  }
  if (f.holistic.size() != static_cast<size_t>(g.size())) {
    return InvalidArgument("feature set holistic descriptor has " +
                           std::to_string(f.holistic.size()) + " values, its grid " +
                           std::to_string(g.size()));
  }
  for (float v : f.holistic) {
    if (!(v >= 0.0f && v <= 1.0f)) {
      return InvalidArgument("feature set holistic descriptor holds a value outside [0, 1]");
    }
  }
  return Status::Ok();
}

}  // namespace sceneloc
