#include "common/matching/neighbourhood.h"

#include <algorithm>
#include <cmath>

#include "common/matching/similarity.h"

namespace sceneloc {
namespace {

// S_A: does the query offset f_i -> f'_m agree with the learnt offset g_j -> g'_n?
float ArrangementSimilarity(const Keypoint& centre, const Keypoint& other, const Neighbour& n) {
  const float dx = other.x - centre.x;
  const float dy = other.y - centre.y;
  const float distance_error = std::hypot(dx, dy) - n.distance_mean;
  const float angle_error = WrapAngle(std::atan2(dy, dx) - n.angle_mean);
  return SimilarityFromSquared(distance_error * distance_error, n.distance_dmax, n.distance_var) *
         SimilarityFromSquared(angle_error * angle_error, n.angle_dmax, n.angle_var);
}

// max_m S_DA(f'_m, g'_n) over the matches of g'_n in [begin, end), excluding f_i itself.
template <typename MatchRange>
float BestNeighbourMatch(const FeatureSet& features, uint32_t feature, const Neighbour& n,
                         const MatchRange& range) {
  const Keypoint& centre = features.keypoints[feature];
  float best = 0;
  for (const DescriptorMatch& m : range) {
    if (m.feature == feature) continue;
    best = std::max(best,
                    m.similarity * ArrangementSimilarity(centre, features.keypoints[m.feature], n));
  }
  return best;
}

// Eq. 2 given a function that yields the matches of a landmark.
template <typename MatchesOf>
float Eq2(const FeatureSet& features, const Map& map, uint32_t feature, uint32_t landmark,
          bool include_centre_term, int max_neighbours, const MatchesOf& matches_of) {
  uint32_t begin = map.neighbour_offsets[landmark];
  uint32_t end = map.neighbour_offsets[landmark + 1];
  if (max_neighbours > 0) end = std::min(end, begin + static_cast<uint32_t>(max_neighbours));
  float numerator = 0;
  float denominator = include_centre_term ? 1.0f : 0.0f;
  float best = 0;
  for (uint32_t k = begin; k < end; ++k) {
    const Neighbour n = map.NeighbourAt(k);
    numerator += n.cooccurrence * BestNeighbourMatch(features, feature, n, matches_of(n.landmark));
    denominator += n.cooccurrence;
    if (denominator > 0) best = std::max(best, numerator / denominator);
  }
  return best;
}

// A view of a contiguous run of matches.
struct Span {
  const DescriptorMatch* b;
  const DescriptorMatch* e;
  const DescriptorMatch* begin() const { return b; }
  const DescriptorMatch* end() const { return e; }
};

}  // namespace

std::vector<float> NeighbourhoodSimilarities(const FeatureSet& features, const Map& map,
                                             const std::vector<DescriptorMatch>& matches,
                                             bool include_centre_term, int max_neighbours,
                                             ThreadPool* pool) {
  return NeighbourhoodSimilarities(features, map, LandmarkScope::Whole(map), matches,
                                   include_centre_term, max_neighbours, pool);
}

std::vector<float> NeighbourhoodSimilarities(const FeatureSet& features, const Map& map,
                                             const LandmarkScope& scope,
                                             const std::vector<DescriptorMatch>& matches,
                                             bool include_centre_term, int max_neighbours,
                                             ThreadPool* pool) {
  // offsets[p]..offsets[p+1]: the matches of the landmark at scope position p.
  const size_t num_landmarks = scope.size();
  std::vector<uint32_t> offsets(num_landmarks + 1, 0);
  for (const DescriptorMatch& m : matches) ++offsets[m.landmark + 1];
  for (size_t p = 0; p < num_landmarks; ++p) offsets[p + 1] += offsets[p];
  const DescriptorMatch* base = matches.data();
  const auto matches_of = [&](uint32_t g) {
    const int32_t p = scope.Position(g);
    if (p < 0) return Span{base, base};
    return Span{base + offsets[p], base + offsets[p + 1]};
  };
  std::vector<float> result(matches.size());
  auto run = [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      result[i] = Eq2(features, map, matches[i].feature, scope.landmark(matches[i].landmark),
                      include_centre_term, max_neighbours, matches_of);
    }
  };
  if (pool != nullptr) {
    pool->ParallelFor(matches.size(), 256, run);
  } else {
    run(0, matches.size());
  }
  return result;
}

float NeighbourhoodSimilarity(const FeatureSet& features, const Map& map,
                              const std::vector<DescriptorMatch>& matches, uint32_t feature,
                              uint32_t landmark, bool include_centre_term, int max_neighbours) {
  const auto matches_of = [&](uint32_t g) {
    std::vector<DescriptorMatch> of;
    for (const DescriptorMatch& m : matches) {
      if (m.landmark == g) of.push_back(m);
    }
    return of;
  };
  return Eq2(features, map, feature, landmark, include_centre_term, max_neighbours, matches_of);
}

}  // namespace sceneloc
