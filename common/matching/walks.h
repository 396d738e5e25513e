// How a map of several walks (map.h experiences: the tour, more walks of the route, new
// ground) is read, between scoring images and answering places (localiser.cc):
//   holistic distances to every image -> z-scores per walk (WalkZ), each walk weighed by how
//   likely the frame shows its ground (WeighByWalk) -> candidates verified per image ->
//   pooled to places (PoolPlaces; the unverified by PlaceMaxima).
// A map of one walk passes through every step unchanged.
//
// Thread-safe: free functions of their arguments.
#pragma once

#include <vector>

#include "common/map/map.h"
#include "common/matching/localiser.h"

namespace sceneloc {

// RobustZ (evidence.h) of `distance` (every image's), each walk read against the distances of
// its own images among `reference` (images; null: every image): a night walk's images all lie
// further from a day query than the day's do, and new ground's from a frame of the route, so
// against one pooled reference a walk's places would stand out, or not, as a block. Read each
// against its own, as a map of that walk alone would read it. A walk with fewer than 20 images
// in the reference is read against the whole reference.
std::vector<float> WalkZ(const Map& map, const std::vector<float>& distance,
                         const std::vector<int>* reference);

// On a map of several walks, each image's z-score is weighed by the probability that the query
// shows its walk's ground at all, from the query's nearest image of that walk against the
// walk's own off-map level (InMapProbability): its posterior weight, exp(z / T) at the map's
// temperature T, is multiplied by that probability (floored at 1e-4). Without it a frame of
// one walk's ground meets another walk's places at their chance level, read against their own
// walk, as if it were one of theirs. A map of one walk, or of walks without their own level,
// is left as it is.
void WeighByWalk(const Map& map, const std::vector<float>& distance, std::vector<float>* z);

// Each candidate (verified per image, `location` the image) names its image and its place, and
// of a place's verified images the best by fused evidence (FuseEvidence) speaks for it (the
// earlier as selected on a tie). On a map of one walk only `image` is filled.
void PoolPlaces(const Map& map, const MatchOptions& options,
                std::vector<CandidateEvidence>* candidates);

// Per place, the largest of its images' `values` (those of a map of one walk as they are).
std::vector<float> PlaceMaxima(const Map& map, const std::vector<float>& values);

}  // namespace sceneloc
