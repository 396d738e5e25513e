// The self-test of a map: localise queries made from the map's own landmarks and check that
// each finds its location. A server runs it on every map it loads (server/map_registry.h), so
// a file that parses but cannot localise (damaged statistics, a training bug) is refused
// before it serves; fuzz/fuzz_map.cc and tests use the same queries.
//
// Thread-safe: free functions; the map is only read.
#pragma once

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/matching/localiser.h"
#include "common/util/status.h"

namespace sceneloc {

// A feature set made from the landmarks tour image `location` holds (at most 1,500): each
// landmark's mean descriptors (unit rows) at the position and size it was seen at in that
// image. Localising it must find `location` (or a neighbour sharing its landmarks) if the
// map is sound. REQUIRES: the map is Validate()d, 0 <= location < map.num_images().
FeatureSet SelfTestFeatures(const Map& map, int location);

// Localises SelfTestFeatures of `probes` locations spread over the tour (the first, the last
// and evenly between; none when probes <= 0) with `options`; FailedPrecondition naming the first
// location that is not among its own ranked answers, or whose query fails. REQUIRES: the map is
// Validate()d and Finalize()d.
Status SelfTestMap(const Map& map, const MatchOptions& options, int probes);

}  // namespace sceneloc
