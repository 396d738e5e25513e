// How a map stores its bulk compactly in memory and on disk: the landmarks' mean
// descriptors and the tour's holistic descriptors as bytes, the context spreads as bytes on
// a log scale, and each co-occurring neighbour in 12 bytes. A 20,000-location map is then
// a few hundred MB, not 2.6 GB, and a server holding two generations during a hot reload
// stays within the machine. The precision kept is far inside what the similarities resolve
// (measured: docs/results.md "Compact maps"):
//   - descriptor components of unit vectors, in [0, 1], in steps of 1/255: a squared
//     distance moves by ~0.001 against the limits of ~0.4 that S_D thresholds at;
//   - holistic cell values, in [0, 1], in steps of 1/255: distances move by ~1e-5 against
//     typical distances of 0.1-0.4;
//   - context spreads (d_max and sigma^2 per histogram) within 3.1% of their value
//     (LogCode, 6.2% steps), where sigma^2 is floored at 0.016 and the similarity reads
//     |d - mu|^2 / sigma^2 against its d_max: a relative error far below the spread between
//     landmarks;
//   - where a landmark was seen: positions in steps of 1/16 pixel (the tour frame's long
//     side is at most 4096), keypoint sizes as binary16 (0.05%), orientations in steps of
//     360/65536 degrees;
//   - neighbour distances in steps of 1/32768 of the frame, their spreads within 2.2%,
//     angles in steps of 1/128 of pi (means: 0.7 degrees at worst against spreads floored
//     at 13 degrees) and 1/255 of pi (largest deviations), angle spreads within 2.2%,
//     co-occurrence in steps of 1/255.
//
// Thread-safe: pure functions.
#pragma once

#include <array>
#include <cstdint>

namespace sceneloc {

// A descriptor component or holistic cell value in [0, 1] as a byte, and back.
uint8_t UnitByte(float value);
inline float UnitValue(uint8_t byte) { return static_cast<float>(byte) * (1.0f / 255.0f); }

// A float as IEEE binary16 bits, and back (round to nearest even).
uint16_t HalfBits(float value);
float HalfValue(uint16_t bits);

// Non-negative values from `low` to `high` as bytes on a log scale: 0 is 0 (and anything
// below low / 2, NaN too), 1..255 run from low to high in 254 equal ratios, so a value
// within the range comes back within half a ratio of itself. Decoding is a table look-up.
class LogCode {
 public:
  LogCode(float low, float high);
  uint8_t Encode(float value) const;
  float Decode(uint8_t code) const { return table_[code]; }
  // The ratio between neighbouring codes.
  float step() const { return step_; }

 private:
  float low_;
  float log_step_;
  float step_;
  std::array<float, 256> table_;
};

// The codes a map uses: context spreads (sigma^2 and d_max of a histogram of unit
// components), from 1e-6 to 4; a neighbour's distance spreads as fractions of the frame,
// from 1/32768 to 2; its angle spreads in radians, from pi/65536 to pi.
const LogCode& ContextSpreadCode();
const LogCode& NeighbourDistanceCode();
const LogCode& NeighbourAngleCode();

// Where a landmark was seen in one tour image, as the map stores it (8 bytes): the
// keypoint's position in 1/16 pixel, its size (diameter, pixels) as binary16 bits and its
// orientation in 360/65536 degrees (OpenCV's convention, [0, 360)).
struct PackedObservation {
  uint16_t x = 0;
  uint16_t y = 0;
  uint16_t size = 0;
  uint16_t angle = 0;

  float X() const { return static_cast<float>(x) * (1.0f / 16); }
  float Y() const { return static_cast<float>(y) * (1.0f / 16); }
  float Size() const { return HalfValue(size); }
  float Angle() const { return static_cast<float>(angle) * (360.0f / 65536); }
};
static_assert(sizeof(PackedObservation) == 8, "PackedObservation is stored as 8 bytes");
// Positions are clamped to [0, 4095.94], angles wrapped into [0, 360).
PackedObservation PackObservation(float x, float y, float size, float angle_deg);

// Statistics of one co-occurring neighbour g' of a landmark g (paper III-B), as S_N reads
// them.
struct Neighbour {
  uint32_t landmark = 0;    // index of g'
  float cooccurrence = 0;   // p(g' | g): images holding both / images holding g
  float distance_mean = 0;  // |pos(g') - pos(g)| over images holding both, pixels
  float distance_var = 0;   // variance of that distance (floored), pixels^2
  float distance_dmax = 0;  // largest |distance - mean|, pixels
  float angle_mean = 0;     // direction of pos(g') - pos(g), radians in (-pi, pi]
  float angle_var = 0;      // circular variance of that angle (floored), radians^2
  float angle_dmax = 0;     // largest wrapped |angle - mean|, radians
};

// A Neighbour as the map stores it. The mean distance is in units of the map frame's long
// side (`frame` pixels) over 32768, so it spans twice the frame; the distance's spreads are
// fractions of the frame (NeighbourDistanceCode), and spreads are standard deviations.
struct PackedNeighbour {
  uint32_t landmark = 0;
  uint16_t distance_mean = 0;
  uint8_t distance_sd = 0;    // NeighbourDistanceCode; > 0 (the variance is floored)
  uint8_t distance_dmax = 0;  // NeighbourDistanceCode
  int8_t angle_mean = 0;      // pi / 128 units, in [-pi, pi)
  uint8_t angle_sd = 0;       // NeighbourAngleCode; > 0
  uint8_t angle_dmax = 0;     // pi / 255 units
  uint8_t cooccurrence = 0;   // 1 / 255 units
};
static_assert(sizeof(PackedNeighbour) == 12, "PackedNeighbour is stored as 12 bytes");

PackedNeighbour Pack(const Neighbour& n, float frame);
Neighbour Unpack(const PackedNeighbour& p, float frame);

}  // namespace sceneloc
