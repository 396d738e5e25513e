#include "tests/support/two_view.h"

#include <cmath>
#include <random>

namespace sceneloc::test {
namespace {

constexpr double kFocal = 400;
constexpr double kCx = 240, kCy = 135;

struct Pixel {
  float x, y;
};

Pixel Project(double x, double y, double z) {
  return {static_cast<float>(kCx + kFocal * x / z), static_cast<float>(kCy + kFocal * y / z)};
}

}  // namespace

std::vector<PointPair> TwoViewPoints(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> depth(4, 8), spread(-0.5, 0.5);
  const double turn = 3 * 3.14159265358979323846 / 180, c = std::cos(turn), s = std::sin(turn);
  std::vector<PointPair> pairs;
  for (int i = 0; i < n; ++i) {
    const double z = depth(rng);
    const double x = spread(rng) * z * 2 * kCx / kFocal, y = spread(rng) * z * 2 * kCy / kFocal;
    const Pixel first = Project(x, y, z);
    // The second camera: centre (0.3, 0, 0.1), turned about the vertical axis.
    const double tx = x - 0.3, tz = z - 0.1;
    const Pixel second = Project(c * tx - s * tz, y, s * tx + c * tz);
    pairs.push_back({first.x, first.y, second.x, second.y});
  }
  return pairs;
}

}  // namespace sceneloc::test
