#include "common/training/calibration.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/features/holistic.h"

namespace sceneloc {
namespace {

float Median(std::vector<float> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

std::vector<float> RotateHolistic180(const float* h, const HolisticGrid& g) {
  std::vector<float> out(static_cast<size_t>(g.size()));
  const int half = g.bins / 2;
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.cols; ++c) {
      const float* from = h + (static_cast<size_t>(r) * g.cols + c) * g.bins;
      float* to =
          out.data() + (static_cast<size_t>(g.rows - 1 - r) * g.cols + (g.cols - 1 - c)) * g.bins;
      for (int b = 0; b < g.bins; ++b) to[(b + half) % g.bins] = from[b];
    }
  }
  return out;
}

Calibration CalibrateImages(const Map& map, int first, int count, ThreadPool* pool,
                            int max_samples) {
  Calibration c;
  if (!map.has_holistic() || map.holistic_grid.bins % 2 != 0 || count <= 0) return c;
  const int samples = std::max(1, std::min(count, max_samples));
  const int shift = std::min(map.options.extractor.holistic.max_shift, map.holistic_grid.cols - 1);
  std::vector<float> nearest(static_cast<size_t>(samples));
  auto measure = [&](size_t begin, size_t end) {
    for (size_t s = begin; s < end; ++s) {
      const int image = first + static_cast<int>(s * static_cast<size_t>(count) / samples);
      const std::vector<float> turned =
          RotateHolistic180(map.HolisticValues(image).data(), map.holistic_grid);
      float best = std::numeric_limits<float>::max();
      for (int l = first; l < first + count; ++l) {
        best = std::min(
            best, HolisticDistance(turned.data(), map.holistic_of(l), map.holistic_grid, shift));
      }
      nearest[s] = best;
    }
  };
  if (pool != nullptr) {
    pool->ParallelFor(nearest.size(), 4, measure);
  } else {
    measure(0, nearest.size());
  }
  c.off_map_distance = Median(nearest);
  std::vector<float> deviation(nearest.size());
  for (size_t i = 0; i < nearest.size(); ++i) {
    deviation[i] = std::abs(nearest[i] - c.off_map_distance);
  }
  // A floor of 2% of the level: a tour of near-identical frames must not make the in-map
  // probability a step function.
  c.off_map_spread = std::max(1.4826f * Median(deviation), 0.02f * c.off_map_distance + 1e-6f);
  c.samples = static_cast<uint32_t>(samples);
  c.valid = true;
  return c;
}

void CalibrateMap(Map* map, ThreadPool* pool, int max_samples) {
  map->calibration = CalibrateImages(*map, 0, map->num_images(), pool, max_samples);
}

}  // namespace sceneloc
