// How a map stores its bulk compactly in memory and on disk: the landmarks' mean
// descriptors and the tour's holistic descriptors as bytes, the context spreads as IEEE
// half floats, and each co-occurring neighbour in 16 bytes. A 20,000-location map is then
// a few hundred MB, not 2.6 GB, and a server holding two generations during a hot reload
// stays within the machine. The precision kept is far inside what the similarities resolve
// (measured: docs/results.md "Compact maps"):
//   - descriptor components of unit vectors, in [0, 1], in steps of 1/255: a squared
//     distance moves by ~0.001 against the limits of ~0.4 that S_D thresholds at;
//   - holistic cell values, in [0, 1], in steps of 1/255: distances move by ~1e-5 against
//     typical distances of 0.1-0.4;
//   - neighbour distances in steps of 1/32768 of the frame, angles of 1/32767 of pi (means),
//     1/65535 of pi (spreads) and 1/255 of pi (largest deviations), co-occurrence in steps
//     of 1/255.
//
// Thread-safe: pure functions.
#pragma once

#include <cstdint>

namespace sceneloc {

// A descriptor component or holistic cell value in [0, 1] as a byte, and back.
uint8_t UnitByte(float value);
inline float UnitValue(uint8_t byte) { return static_cast<float>(byte) * (1.0f / 255.0f); }

// A float as IEEE binary16 bits, and back (round to nearest even).
uint16_t HalfBits(float value);
float HalfValue(uint16_t bits);

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

// A Neighbour as the map stores it. Distances are in units of the map frame's long side
// (`frame` pixels) over 32768, so they span twice the frame; spreads are standard
// deviations.
struct PackedNeighbour {
  uint32_t landmark = 0;
  uint16_t distance_mean = 0;
  uint16_t distance_sd = 0;  // > 0 (the variance is floored)
  uint16_t distance_dmax = 0;
  int16_t angle_mean = 0;    // pi / 32767 units
  uint16_t angle_sd = 0;     // pi / 65535 units; > 0
  uint8_t angle_dmax = 0;    // pi / 255 units
  uint8_t cooccurrence = 0;  // 1 / 255 units
};
static_assert(sizeof(PackedNeighbour) == 16, "PackedNeighbour is stored as 16 bytes");

PackedNeighbour Pack(const Neighbour& n, float frame);
Neighbour Unpack(const PackedNeighbour& p, float frame);

}  // namespace sceneloc
