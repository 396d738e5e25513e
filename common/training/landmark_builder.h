// Landmark fusion (paper II-B): turns each track into a landmark model: the mean local
// descriptor with its d_max and sigma^2, the mean context descriptor with d_max and
// sigma^2 per histogram, and where the landmark was seen.
#pragma once

#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/training/tour_features.h"
#include "common/training/tracker.h"

namespace sceneloc {

// Fills the landmark arrays and observations of `map` (one landmark per track, in track
// order) and leaves quality zero, neighbours and image lists empty. Variances are floored
// at options.local_var_floor / context_var_floor. REQUIRES: every observation of every
// track is of a feature that exists in `tour` (the window holds its image).
void FuseLandmarks(const std::vector<Track>& tracks, const TourWindow& tour,
                   const TrainOptions& options, Map* map);

}  // namespace sceneloc
