// The compact values a map stores (common/map/compact.h): each comes back within the
// precision the header promises.
#include "common/map/compact.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace sceneloc {
namespace {

constexpr float kPi = 3.14159265358979f;

// A value within a log code's range comes back within half a step of itself; 0, negative
// and NaN values are 0; values past the ends are the ends.
TEST(LogCodeTest, RoundTripsWithinHalfAStep) {
  const LogCode& code = ContextSpreadCode();
  const float half_step = std::sqrt(code.step());
  for (float v = 1e-6f; v <= 4.0f; v *= 1.37f) {
    const float back = code.Decode(code.Encode(v));
    EXPECT_LE(back / v, half_step * 1.0001f) << v;
    EXPECT_GE(back / v, 1 / (half_step * 1.0001f)) << v;
  }
  EXPECT_NEAR(code.step(), 1.062f, 0.001f);  // the header's 6.2% steps
  EXPECT_EQ(code.Encode(0), 0);
  EXPECT_EQ(code.Decode(0), 0.0f);
  EXPECT_EQ(code.Encode(-1), 0);
  EXPECT_EQ(code.Encode(std::numeric_limits<float>::quiet_NaN()), 0);
  EXPECT_EQ(code.Encode(1e-9f), 0);  // below half the lowest value
  EXPECT_EQ(code.Encode(0.8e-6f), 1);
  EXPECT_EQ(code.Encode(100), 255);
  EXPECT_FLOAT_EQ(code.Decode(255), 4.0f);
  // Codes increase with the value.
  for (int c = 1; c < 255; ++c) EXPECT_LT(code.Decode(c), code.Decode(c + 1));
}

// A neighbour packed in 12 bytes comes back within the header's precision.
TEST(PackedNeighbourTest, KeepsThePrecisionPromised) {
  const float frame = 960;
  // Half a step of each log code, relative: 2.2%.
  const float distance = std::sqrt(NeighbourDistanceCode().step()) * 1.0001f - 1;
  const float angle = std::sqrt(NeighbourAngleCode().step()) * 1.0001f - 1;
  EXPECT_LT(distance, 0.0222f);
  EXPECT_LT(angle, 0.0222f);
  for (int i = 0; i < 200; ++i) {
    Neighbour n;
    n.landmark = 1000u * i;
    n.cooccurrence = 0.005f * i;
    n.distance_mean = 4.7f * i;
    n.distance_var = std::pow(20.0f + 1.9f * i, 2.0f);
    n.distance_dmax = 0.5f + 3.1f * i;
    n.angle_mean = -kPi + 0.0314f * i;
    n.angle_var = std::pow(0.23f + 0.01f * i, 2.0f);
    n.angle_dmax = 0.0157f * i;
    const Neighbour b = Unpack(Pack(n, frame), frame);
    EXPECT_EQ(b.landmark, n.landmark);
    EXPECT_NEAR(b.cooccurrence, n.cooccurrence, 0.5f / 255 + 1e-6f);
    EXPECT_NEAR(b.distance_mean, n.distance_mean, 0.5f * frame / 32768 + 1e-4f);
    EXPECT_NEAR(std::sqrt(b.distance_var), std::sqrt(n.distance_var),
                distance * std::sqrt(n.distance_var));
    EXPECT_NEAR(b.distance_dmax, n.distance_dmax, distance * n.distance_dmax);
    EXPECT_NEAR(b.angle_mean, n.angle_mean, 0.5f * kPi / 128 + 1e-6f);
    EXPECT_NEAR(std::sqrt(b.angle_var), std::sqrt(n.angle_var), angle * std::sqrt(n.angle_var));
    EXPECT_NEAR(b.angle_dmax, n.angle_dmax, 0.5f * kPi / 255 + 1e-6f);
  }
  // Spreads are never 0: the variances are floored.
  Neighbour zero;
  const PackedNeighbour p = Pack(zero, frame);
  EXPECT_GT(p.distance_sd, 0);
  EXPECT_GT(p.angle_sd, 0);
}

}  // namespace
}  // namespace sceneloc
