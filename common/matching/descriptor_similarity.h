// S_D (paper III-A): the descriptor similarity of every feature of an image to every
// landmark of a map, keeping the pairs with S_D >= s_min.
//
//   S_D(f, g) = sim(|a_f - mu_g|; d_max, sigma^2) * mean_h sim(|c_f,h - mu_g,h|; d_max,h,
//   sigma^2_h)
//
// Since the context mean is at most 1, S_D >= s_min needs sim_local >= s_min: a squared
// local distance within the landmark's limit. Most pairs are ruled out without their
// distance: a lower bound on it for all pairs at once comes from one matrix product per
// block of landmarks in a 32-dimensional projection (Map::local_basis, the principal axes
// of the landmarks' means), plus the norms of what the projection leaves out; only pairs
// the bound cannot rule out (about 4% on the Gardens Point map; 0.7% pass) get the exact
// distance and then the context term. The answer is the same as computing every pair
// (tested against DescriptorSimilarity). This is the hot loop of both recognition and
// training.
#pragma once

#include <cstdint>
#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/matching/landmark_scope.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

struct DescriptorMatch {
  uint32_t feature = 0;
  uint32_t landmark = 0;  // the landmark's position in the scope (its map index when whole)
  float similarity = 0;   // S_D, in [s_min, 1]
};

// Returns every (feature, landmark) pair with S_D >= s_min, ordered by landmark, then by
// feature; with max_per_landmark > 0, only the max_per_landmark best features of each
// landmark (ties: the lower feature index). The cap is a work budget: a query of many
// identical features (a hostile one) would otherwise match every landmark it resembles
// thousands of times, and S_N walks those matches for every neighbour, quadratically.
// `pool` may be null (runs inline). REQUIRES: map.Finalize() was called, 0 < s_min <= 1.
// Thread-safe for concurrent calls on the same map.
std::vector<DescriptorMatch> ComputeDescriptorMatches(const FeatureSet& features, const Map& map,
                                                      float s_min, ThreadPool* pool,
                                                      int max_per_landmark = 0);

// The same over the landmarks of `scope` only, which number the matches' landmarks. The
// matches of a landmark are those of the whole map's computation.
std::vector<DescriptorMatch> ComputeDescriptorMatches(const FeatureSet& features, const Map& map,
                                                      const LandmarkScope& scope, float s_min,
                                                      ThreadPool* pool, int max_per_landmark);

// S_D of one pair, computed directly (the reference the fast path is tested against).
float DescriptorSimilarity(const FeatureSet& features, int feature, const Map& map, int landmark);

}  // namespace sceneloc
