// Small, valid, reproducible landmark maps for tests, made in code from a seeded RNG.
#pragma once

#include <cstdint>

#include "common/map/map.h"

namespace sceneloc::test {

// A map of `num_landmarks` landmarks over a tour of `num_images` images, as training
// might produce it: each landmark is a track over 2..5 consecutive images (1 when the
// tour has one image), with unit-norm descriptors, floored variances, image lists that
// match the observations, and up to options.max_neighbours co-occurring neighbours
// each, nearest first. Default TrainOptions. The result passes Validate() and is
// Finalize()d. The same arguments give the same map on the same standard library.
// REQUIRES: num_images >= 1, num_landmarks >= 0.
Map MakeRandomMap(int num_images, int num_landmarks, uint32_t seed);

// A descriptor row as a map stores it (UnitByte of each value).
Eigen::Matrix<uint8_t, 1, kDescriptorSize> DescriptorBytesOf(
    const Eigen::Matrix<float, 1, kDescriptorSize>& values);

// Expects (gtest EXPECT_*) that every stored field of `a` and `b` is equal, bit for bit
// for floats, plus the derived local_mean_sqnorm.
void ExpectMapsEqual(const Map& a, const Map& b);

}  // namespace sceneloc::test
