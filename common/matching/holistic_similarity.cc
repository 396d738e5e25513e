#include "common/matching/holistic_similarity.h"

#include <algorithm>

#include "common/features/holistic.h"

namespace sceneloc {

std::vector<float> HolisticDistances(const FeatureSet& query, const Map& map, int max_shift,
                                     ThreadPool* pool) {
  if (!map.has_holistic() || query.holistic.empty()) return {};
  const HolisticGrid& grid = map.holistic_grid;
  const int shift = std::clamp(max_shift, 0, grid.cols - 1);
  std::vector<float> distance(static_cast<size_t>(map.num_images()));
  auto run = [&](size_t begin, size_t end) {
    for (size_t l = begin; l < end; ++l) {
      distance[l] = HolisticDistance(query.holistic.data(), map.holistic_of(static_cast<int>(l)),
                                     grid, shift);
    }
  };
  if (pool != nullptr) {
    pool->ParallelFor(distance.size(), 64, run);
  } else {
    run(0, distance.size());
  }
  return distance;
}

std::vector<float> HolisticDistancesTo(const FeatureSet& query, const Map& map,
                                       const std::vector<int>& locations, int max_shift,
                                       ThreadPool* pool) {
  if (!map.has_holistic() || query.holistic.empty()) return {};
  const HolisticGrid& grid = map.holistic_grid;
  const int shift = std::clamp(max_shift, 0, grid.cols - 1);
  std::vector<float> distance(locations.size());
  auto run = [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      distance[i] =
          HolisticDistance(query.holistic.data(), map.holistic_of(locations[i]), grid, shift);
    }
  };
  if (pool != nullptr) {
    pool->ParallelFor(distance.size(), 64, run);
  } else {
    run(0, distance.size());
  }
  return distance;
}

}  // namespace sceneloc
