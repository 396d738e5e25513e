#include "common/map/compact.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

namespace sceneloc {
namespace {

constexpr float kPi = 3.14159265358979f;

// `value / unit` rounded into [low, high].
int Quantise(float value, float unit, int low, int high) {
  const float q = std::round(value / unit);
  if (!(q >= static_cast<float>(low))) return low;  // NaN too
  return q > static_cast<float>(high) ? high : static_cast<int>(q);
}

}  // namespace

uint8_t UnitByte(float value) {
  return static_cast<uint8_t>(Quantise(value, 1.0f / 255.0f, 0, 255));
}

uint16_t HalfBits(float value) { return Eigen::numext::bit_cast<uint16_t>(Eigen::half(value)); }

float HalfValue(uint16_t bits) {
  return static_cast<float>(Eigen::numext::bit_cast<Eigen::half>(bits));
}

PackedNeighbour Pack(const Neighbour& n, float frame) {
  const float distance_unit = frame / 32768.0f;
  PackedNeighbour p;
  p.landmark = n.landmark;
  p.distance_mean = static_cast<uint16_t>(Quantise(n.distance_mean, distance_unit, 0, 65535));
  p.distance_sd =
      static_cast<uint16_t>(Quantise(std::sqrt(n.distance_var), distance_unit, 1, 65535));
  p.distance_dmax = static_cast<uint16_t>(Quantise(n.distance_dmax, distance_unit, 0, 65535));
  p.angle_mean = static_cast<int16_t>(Quantise(n.angle_mean, kPi / 32767.0f, -32767, 32767));
  p.angle_sd = static_cast<uint16_t>(Quantise(std::sqrt(n.angle_var), kPi / 65535.0f, 1, 65535));
  p.angle_dmax = static_cast<uint8_t>(Quantise(n.angle_dmax, kPi / 255.0f, 0, 255));
  p.cooccurrence = static_cast<uint8_t>(Quantise(n.cooccurrence, 1.0f / 255.0f, 0, 255));
  return p;
}

Neighbour Unpack(const PackedNeighbour& p, float frame) {
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

}  // namespace sceneloc
