// Eq. 1 of the paper: the similarity of a value at distance d from a learnt mean,
// given the largest distance seen in training (d_max) and the variance sigma^2:
//   sim = 1                                  if d <= d_max
//   sim = exp(-(d^2 - d_max^2) / (2 sigma^2)) otherwise
// (the paper's kappa * exp(-d^2 / 2 sigma^2) with kappa = exp(d_max^2 / 2 sigma^2)).
// Used for descriptors (S_D) and for the spatial arrangement of neighbours (S_A).
#pragma once

#include <cmath>

namespace sceneloc {

// REQUIRES: var > 0. Takes squared distances so callers can skip a sqrt.
inline float SimilarityFromSquared(float d2, float dmax, float var) {
  const float dmax2 = dmax * dmax;
  if (d2 <= dmax2) return 1.0f;
  return std::exp(-(d2 - dmax2) / (2.0f * var));
}

// The largest squared distance whose similarity is still >= s_min (0 < s_min <= 1):
// sim >= s_min  <=>  d^2 <= d_max^2 + 2 sigma^2 ln(1 / s_min).
inline float SquaredDistanceLimit(float dmax, float var, float s_min) {
  return dmax * dmax + 2.0f * var * std::log(1.0f / s_min);
}

// Wraps an angle difference to [-pi, pi].
inline float WrapAngle(float a) {
  constexpr float kPi = 3.14159265358979f;
  a = std::fmod(a + kPi, 2.0f * kPi);
  if (a < 0) a += 2.0f * kPi;
  return a - kPi;
}

}  // namespace sceneloc
