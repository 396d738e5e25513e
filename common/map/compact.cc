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

PackedObservation PackObservation(float x, float y, float size, float angle_deg) {
  PackedObservation p;
  p.x = static_cast<uint16_t>(Quantise(x, 1.0f / 16, 0, 65535));
  p.y = static_cast<uint16_t>(Quantise(y, 1.0f / 16, 0, 65535));
  p.size = HalfBits(size);
  float wrapped = std::fmod(angle_deg, 360.0f);
  if (wrapped < 0) wrapped += 360.0f;
  p.angle = static_cast<uint16_t>(Quantise(wrapped, 360.0f / 65536, 0, 65536) & 0xFFFF);
  return p;
}

LogCode::LogCode(float low, float high)
    : low_(low), log_step_(std::log(high / low) / 254.0f), step_(std::exp(log_step_)) {
  table_[0] = 0;
  for (int c = 1; c < 256; ++c) table_[c] = low * std::exp(log_step_ * static_cast<float>(c - 1));
}

uint8_t LogCode::Encode(float value) const {
  if (!(value >= 0.5f * low_)) return 0;  // NaN too
  const float c = 1 + std::round(std::log(std::max(value, low_) / low_) / log_step_);
  return static_cast<uint8_t>(std::min(c, 255.0f));
}

const LogCode& ContextSpreadCode() {
  static const LogCode code(1e-6f, 4.0f);
  return code;
}

const LogCode& NeighbourDistanceCode() {
  static const LogCode code(1.0f / 32768.0f, 2.0f);
  return code;
}

const LogCode& NeighbourAngleCode() {
  static const LogCode code(kPi / 65536.0f, kPi);
  return code;
}

PackedNeighbour Pack(const Neighbour& n, float frame) {
  const float distance_unit = frame / 32768.0f;
  PackedNeighbour p;
  p.landmark = n.landmark;
  p.distance_mean = static_cast<uint16_t>(Quantise(n.distance_mean, distance_unit, 0, 65535));
  const LogCode& distance = NeighbourDistanceCode();
  p.distance_sd = std::max<uint8_t>(1, distance.Encode(std::sqrt(n.distance_var) / frame));
  p.distance_dmax = distance.Encode(n.distance_dmax / frame);
  // pi / 128 units, +pi (128) wrapped to -pi (-128): the same direction.
  const int angle = Quantise(n.angle_mean, kPi / 128.0f, -128, 128);
  p.angle_mean = static_cast<int8_t>(angle == 128 ? -128 : angle);
  p.angle_sd = std::max<uint8_t>(1, NeighbourAngleCode().Encode(std::sqrt(n.angle_var)));
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
  const LogCode& distance = NeighbourDistanceCode();
  const float distance_sd = distance.Decode(p.distance_sd) * frame;
  n.distance_var = distance_sd * distance_sd;
  n.distance_dmax = distance.Decode(p.distance_dmax) * frame;
  n.angle_mean = p.angle_mean * (kPi / 128.0f);
  const float angle_sd = NeighbourAngleCode().Decode(p.angle_sd);
  n.angle_var = angle_sd * angle_sd;
  n.angle_dmax = p.angle_dmax * (kPi / 255.0f);
  return n;
}

}  // namespace sceneloc
