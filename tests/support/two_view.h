// Corresponding points of one rigid scene seen from two places, for tests of geometric
// verification: made in code from a seeded RNG, with exact projections (no noise).
#pragma once

#include <cstdint>
#include <vector>

namespace sceneloc::test {

// Where one scene point appears in the first view (x0, y0) and in the second (x1, y1),
// pixels of a 480x270 frame.
struct PointPair {
  float x0, y0, x1, y1;
};

// `n` random scene points 4-8 m in front of a pinhole camera (focal 400 px) and their
// images in it and in a second camera 0.3 m to the side, 0.1 m forward and turned 3
// degrees: a general two-view geometry (not a plane, not a pure rotation), so a
// fundamental matrix explains every pair. The same arguments give the same pairs.
std::vector<PointPair> TwoViewPoints(int n, uint32_t seed);

}  // namespace sceneloc::test
