// Geometric verification of the best candidate locations (a departure from the paper,
// measured in docs/results.md): for a candidate tour image l, each landmark of G_l that
// the query matched gives a correspondence between its best query feature and where the
// landmark was seen in l; the number of those correspondences that are inliers of a
// RANSAC fundamental matrix says whether the query really views the same scene as l.
#pragma once

#include <cstdint>
#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"

namespace sceneloc {

// Epipolar inliers between the query and tour image `location`. best_score[g] and
// best_feature[g] are max_f S(f, g) and its argmax (-1 when g matched nothing).
// Returns 0 when fewer than 8 correspondences exist. RANSAC stops after max_iterations.
int CountEpipolarInliers(const FeatureSet& features, const Map& map, int location,
                         const std::vector<float>& best_score,
                         const std::vector<int32_t>& best_feature, double ransac_threshold_px,
                         int max_iterations);

}  // namespace sceneloc
