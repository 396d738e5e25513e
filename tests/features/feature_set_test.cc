// Checks of feature sets from untrusted sources (common/features/feature_set.h): a sound
// set passes, and each kind of inconsistency is refused with a message saying what.
#include "common/features/feature_set.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

namespace sceneloc {
namespace {

// `n` keypoints with unit descriptors and a 2 x 1 x 3 holistic descriptor, seeded.
FeatureSet SoundSet(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0, 1);
  FeatureSet f;
  f.image_width = 480;
  f.image_height = 270;
  for (int i = 0; i < n; ++i) f.keypoints.push_back({u(rng) * 480, u(rng) * 270, 3, 45, 0.1f, 1});
  f.local = DescriptorMatrix::Random(n, kDescriptorSize).rowwise().normalized();
  f.context = DescriptorMatrix::Random(n, kDescriptorSize).rowwise().normalized();
  f.holistic_grid = {2, 1, 3};
  for (int i = 0; i < 6; ++i) f.holistic.push_back(u(rng));
  return f;
}

void ExpectRefused(const FeatureSet& f, const std::string& expected) {
  const Status status = ValidateFeatureSet(f);
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << status.ToString();
  EXPECT_NE(status.message().find(expected), std::string::npos) << status.message();
}

// A consistent set passes, and so does one with no keypoints and no holistic descriptor.
TEST(FeatureSetTest, SoundSetsPass) {
  EXPECT_TRUE(ValidateFeatureSet(SoundSet(20, 1)).ok());
  FeatureSet empty;
  empty.image_width = 10;
  empty.image_height = 10;
  EXPECT_TRUE(ValidateFeatureSet(empty).ok());
}

// The image size must be positive.
TEST(FeatureSetTest, RefusesNonPositiveSize) {
  FeatureSet f = SoundSet(3, 2);
  f.image_height = 0;
  ExpectRefused(f, "image size must be positive");
}

// Descriptor rows must match the keypoints one to one.
TEST(FeatureSetTest, RefusesMismatchedDescriptorCounts) {
  FeatureSet f = SoundSet(5, 3);
  f.context.conservativeResize(4, Eigen::NoChange);
  ExpectRefused(f, "5 keypoints but 5 local and 4 context descriptors");
}

// A NaN or an infinity in a descriptor or a keypoint is refused.
TEST(FeatureSetTest, RefusesNonFiniteNumbers) {
  FeatureSet f = SoundSet(5, 4);
  f.local(2, 7) = std::numeric_limits<float>::quiet_NaN();
  ExpectRefused(f, "descriptors hold a non-finite number");
  f = SoundSet(5, 4);
  f.keypoints[3].angle = std::numeric_limits<float>::infinity();
  ExpectRefused(f, "keypoint 3 holds a non-finite number");
}

// The holistic grid must be in range, hold as many values as it says, each in [0, 1].
TEST(FeatureSetTest, RefusesABadHolisticDescriptor) {
  FeatureSet f = SoundSet(2, 5);
  f.holistic_grid.bins = 37;
  ExpectRefused(f, "holistic grid is out of range");
  f = SoundSet(2, 5);
  f.holistic.pop_back();
  ExpectRefused(f, "holistic descriptor has 5 values, its grid 6");
  f = SoundSet(2, 5);
  f.holistic[0] = 1.5f;
  ExpectRefused(f, "outside [0, 1]");
  f.holistic[0] = std::numeric_limits<float>::quiet_NaN();
  ExpectRefused(f, "outside [0, 1]");
}

}  // namespace
}  // namespace sceneloc
