#include "common/map/map_layout.h"

#include <algorithm>
#include <cmath>

namespace sceneloc::map_io_internal {
namespace {

constexpr float kPi = 3.14159265358979f;

}  // namespace

Neighbour UnpackV5(const PackedNeighbourV5& p, float frame) {
  const float distance_unit = frame / 32768.0f;
  Neighbour n;
  n.landmark = p.landmark;
  n.cooccurrence = p.cooccurrence * (1.0f / 255.0f);
  n.distance_mean = p.distance_mean * distance_unit;
  const float distance_sd = p.distance_sd * distance_unit;
  n.distance_var = distance_sd * distance_sd;
  n.distance_dmax = p.distance_dmax * distance_unit;
  n.angle_mean = p.angle_mean * (kPi / 32767.0f);
  const float angle_sd = p.angle_sd * (kPi / 65535.0f);
  n.angle_var = angle_sd * angle_sd;
  n.angle_dmax = p.angle_dmax * (kPi / 255.0f);
  return n;
}

PackedNeighbourV5 PackV5(const Neighbour& n, float frame) {
  // Rounded into [low, high] (NaN: low).
  const auto quantise = [](float value, float unit, int low, int high) {
    const float q = std::round(value / unit);
    if (!(q >= static_cast<float>(low))) return low;
    return q > static_cast<float>(high) ? high : static_cast<int>(q);
  };
  const float distance_unit = frame / 32768.0f;
  PackedNeighbourV5 p;
  p.landmark = n.landmark;
  p.distance_mean = static_cast<uint16_t>(quantise(n.distance_mean, distance_unit, 0, 65535));
  p.distance_sd =
      static_cast<uint16_t>(quantise(std::sqrt(n.distance_var), distance_unit, 1, 65535));
  p.distance_dmax = static_cast<uint16_t>(quantise(n.distance_dmax, distance_unit, 0, 65535));
  p.angle_mean = static_cast<int16_t>(quantise(n.angle_mean, kPi / 32767.0f, -32767, 32767));
  p.angle_sd = static_cast<uint16_t>(quantise(std::sqrt(n.angle_var), kPi / 65535.0f, 1, 65535));
  p.angle_dmax = static_cast<uint8_t>(quantise(n.angle_dmax, kPi / 255.0f, 0, 255));
  p.cooccurrence = static_cast<uint8_t>(quantise(n.cooccurrence, 1.0f / 255.0f, 0, 255));
  return p;
}

void UpgradeV1(const V1Fields& v1, Map* map) {
  TrainOptions& o = map->options;
  const double long_side = std::max(1, map->frame_long_side());
  o.extractor.working_size = map->frame_long_side();
  o.extractor.holistic.cols = 0;
  o.ransac_threshold = v1.ransac_threshold_px / long_side;
  o.distance_sd_floor = std::sqrt(std::max(0.0, v1.distance_var_floor)) / long_side;
  o.min_landmarks_per_image = 0;
}

}  // namespace sceneloc::map_io_internal
