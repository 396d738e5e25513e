#include "common/training/cooccurrence.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "common/matching/similarity.h"

namespace sceneloc {
namespace {

struct Offset {
  float distance;
  float angle;
};

// The displacement from g to g' in every image that holds both (observations of each
// landmark are sorted by image, so this is a merge).
std::vector<Offset> SharedOffsets(const Map& map, uint32_t g, uint32_t h) {
  std::vector<Offset> out;
  uint32_t a = map.observation_offsets[g], a_end = map.observation_offsets[g + 1];
  uint32_t b = map.observation_offsets[h], b_end = map.observation_offsets[h + 1];
  while (a < a_end && b < b_end) {
    if (map.observation_image[a] < map.observation_image[b]) {
      ++a;
    } else if (map.observation_image[b] < map.observation_image[a]) {
      ++b;
    } else {
      const float dx = map.ObservationX(b) - map.ObservationX(a);
      const float dy = map.ObservationY(b) - map.ObservationY(a);
      out.push_back({std::hypot(dx, dy), std::atan2(dy, dx)});
      ++a;
      ++b;
    }
  }
  return out;
}

Neighbour MakeNeighbour(const Map& map, const TrainOptions& options, uint32_t g, uint32_t h,
                        const std::vector<Offset>& offsets) {
  Neighbour n;
  n.landmark = h;
  const float count = static_cast<float>(offsets.size());
  n.cooccurrence =
      count / static_cast<float>(map.observation_offsets[g + 1] - map.observation_offsets[g]);
  float sum_d = 0, sum_sin = 0, sum_cos = 0;
  for (const Offset& o : offsets) {
    sum_d += o.distance;
    sum_sin += std::sin(o.angle);
    sum_cos += std::cos(o.angle);
  }
  n.distance_mean = sum_d / count;
  n.angle_mean = std::atan2(sum_sin, sum_cos);
  float var_d = 0, var_a = 0;
  for (const Offset& o : offsets) {
    const float dd = o.distance - n.distance_mean;
    const float da = WrapAngle(o.angle - n.angle_mean);
    var_d += dd * dd;
    var_a += da * da;
    n.distance_dmax = std::max(n.distance_dmax, std::abs(dd));
    n.angle_dmax = std::max(n.angle_dmax, std::abs(da));
  }
  const double sd_floor_px = options.distance_sd_floor * map.frame_long_side();
  n.distance_var = std::max(var_d / count, static_cast<float>(sd_floor_px * sd_floor_px));
  n.angle_var = std::max(var_a / count, static_cast<float>(options.angle_var_floor));
  return n;
}

}  // namespace

void BuildImageLists(Map* map) {
  const size_t num_images = map->image_names.size();
  std::vector<std::vector<uint32_t>> lists(num_images);
  for (size_t g = 0; g + 1 < map->observation_offsets.size(); ++g) {
    for (uint32_t o = map->observation_offsets[g]; o < map->observation_offsets[g + 1]; ++o) {
      lists[map->observation_image[o]].push_back(static_cast<uint32_t>(g));
    }
  }
  map->image_offsets.assign(1, 0);
  map->image_landmarks.clear();
  for (const auto& list : lists) {
    map->image_landmarks.insert(map->image_landmarks.end(), list.begin(), list.end());
    map->image_offsets.push_back(static_cast<uint32_t>(map->image_landmarks.size()));
  }
}

void BuildNeighbours(const TrainOptions& options, Map* map) {
  BuildImageLists(map);
  const size_t num_landmarks = static_cast<size_t>(map->num_landmarks());
  map->neighbour_offsets.assign(1, 0);
  map->neighbours.clear();
  std::vector<uint32_t> seen_stamp(num_landmarks, UINT32_MAX);
  std::vector<std::array<float, 2>> mean(num_landmarks);
  for (size_t g = 0; g < num_landmarks; ++g) mean[g] = map->MeanPosition(static_cast<int>(g));
  for (size_t g = 0; g < num_landmarks; ++g) {
    // Every landmark sharing an image with g, by distance between mean positions.
    std::vector<std::pair<float, uint32_t>> near;
    for (uint32_t o = map->observation_offsets[g]; o < map->observation_offsets[g + 1]; ++o) {
      const uint32_t image = map->observation_image[o];
      for (uint32_t k = map->image_offsets[image]; k < map->image_offsets[image + 1]; ++k) {
        const uint32_t h = map->image_landmarks[k];
        if (h == g || seen_stamp[h] == g) continue;
        seen_stamp[h] = static_cast<uint32_t>(g);
        const float d = std::hypot(mean[h][0] - mean[g][0], mean[h][1] - mean[g][1]);
        near.emplace_back(d, h);
      }
    }
    const size_t keep = std::min(near.size(), static_cast<size_t>(options.max_neighbours));
    std::partial_sort(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(keep), near.end());
    for (size_t k = 0; k < keep; ++k) {
      const uint32_t h = near[k].second;
      map->neighbours.push_back(
          Pack(MakeNeighbour(*map, options, static_cast<uint32_t>(g), h,
                             SharedOffsets(*map, static_cast<uint32_t>(g), h)),
               static_cast<float>(map->frame_long_side())));
    }
    map->neighbour_offsets.push_back(static_cast<uint32_t>(map->neighbours.size()));
  }
}

}  // namespace sceneloc
