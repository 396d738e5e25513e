// Holistic evidence (our departure from the paper; common/features/holistic.h): how much
// the query frame as a whole looks like each tour image.
#pragma once

#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

// The holistic distance (HolisticDistance) of the query to every tour image, allowing
// `max_shift` cells of lateral offset; empty when the query or the map has no holistic
// descriptor. `pool` may be null. REQUIRES: the query's grid equals the map's when both
// are present (Localise checks it).
std::vector<float> HolisticDistances(const FeatureSet& query, const Map& map, int max_shift,
                                     ThreadPool* pool);

// The holistic distance to the tour images `locations` only, in their order.
std::vector<float> HolisticDistancesTo(const FeatureSet& query, const Map& map,
                                       const std::vector<int>& locations, int max_shift,
                                       ThreadPool* pool);

}  // namespace sceneloc
