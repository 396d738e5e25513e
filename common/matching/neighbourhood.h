// S_N (paper III-B, eq. 2): how well the neighbourhood of a feature f_i in the query
// agrees with the learnt neighbourhood of landmark g_j.
//
//   S_N(f_i, g_j) = max_k  sum_{n=1..k} p(g'_n|g_j) max_m S_DA(f'_m, g'_n)
//                          / (c + sum_{n=1..k} p(g'_n|g_j))
//   S_DA = S_D(f'_m, g'_n) * S_A,  S_A = sim(distance) * sim(angle)  (eq. 1 form)
//
// where g'_n are g_j's neighbours nearest first, f'_m ranges over the other query features
// matched to g'_n with S_D >= s_min, distance and angle are those of f'_m - f_i against the
// stored statistics of g'_n - g_j, and c = 1 when the centre term is included.
#pragma once

#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/matching/descriptor_similarity.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

// S_N for every match in `matches` (which must be ordered by landmark, as
// ComputeDescriptorMatches returns them, numbered by `scope`). A neighbour outside the scope
// matched nothing. max_neighbours == 0 walks all stored neighbours.
std::vector<float> NeighbourhoodSimilarities(const FeatureSet& features, const Map& map,
                                             const LandmarkScope& scope,
                                             const std::vector<DescriptorMatch>& matches,
                                             bool include_centre_term, int max_neighbours,
                                             ThreadPool* pool);

// The same with the whole map as the scope.
std::vector<float> NeighbourhoodSimilarities(const FeatureSet& features, const Map& map,
                                             const std::vector<DescriptorMatch>& matches,
                                             bool include_centre_term, int max_neighbours,
                                             ThreadPool* pool);

// S_N of one pair, with the same meaning (the brute-force reference for tests).
float NeighbourhoodSimilarity(const FeatureSet& features, const Map& map,
                              const std::vector<DescriptorMatch>& matches, uint32_t feature,
                              uint32_t landmark, bool include_centre_term, int max_neighbours);

}  // namespace sceneloc
