#include "common/matching/descriptor_similarity.h"

#include <gtest/gtest.h>

#include <random>

#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

// Query features near some of the map's landmarks (so pairs survive S_min) plus noise.
FeatureSet FeaturesNear(const Map& map, int count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, 0.03f);
  std::uniform_int_distribution<int> pick(0, map.num_landmarks() - 1);
  FeatureSet f;
  f.image_width = 640;
  f.image_height = 360;
  f.local.resize(count, kDescriptorSize);
  f.context.resize(count, kDescriptorSize);
  for (int i = 0; i < count; ++i) {
    const int g = pick(rng);
    for (int c = 0; c < kDescriptorSize; ++c) {
      f.local(i, c) = map.LocalMeanRow(g)[c] + noise(rng);
      f.context(i, c) = map.ContextMeanRow(g)[c] + noise(rng);
    }
    f.local.row(i).normalize();
    f.context.row(i).normalize();
    f.keypoints.push_back({float(i % 640), float(i % 360), 4, 0, 1, 0});
  }
  return f;
}

// The blocked matrix-product path returns exactly the pairs the per-pair reference says
// are >= S_min, with the same S_D, for 1 and 2 threads.
TEST(DescriptorSimilarityTest, MatchesBruteForceReference) {
  Map map = test::MakeRandomMap(20, 1300, 7);  // > 2 landmark blocks
  for (int g = 0; g < map.num_landmarks(); ++g) {
    map.local_var[g] = 0.05f;  // wide enough that perturbed features survive
    map.context_var.row(g).setConstant(0.01f);
  }
  const FeatureSet f = FeaturesNear(map, 300, 3);
  const float s_min = 0.3f;
  std::vector<DescriptorMatch> expected;
  for (int g = 0; g < map.num_landmarks(); ++g) {
    for (int i = 0; i < f.size(); ++i) {
      const float s = DescriptorSimilarity(f, i, map, g);
      if (s >= s_min) expected.push_back({uint32_t(i), uint32_t(g), s});
    }
  }
  ASSERT_GT(expected.size(), 200u);
  for (int threads : {1, 2}) {
    ThreadPool pool(threads);
    const auto got = ComputeDescriptorMatches(f, map, s_min, &pool);
    size_t near_threshold = 0;
    size_t j = 0;
    for (const DescriptorMatch& e : expected) {
      if (j < got.size() && got[j].feature == e.feature && got[j].landmark == e.landmark) {
        EXPECT_NEAR(got[j].similarity, e.similarity, 1e-4);
        ++j;
      } else {
        // Only a pair within float rounding of S_min may differ between the two paths.
        EXPECT_NEAR(e.similarity, s_min, 1e-3);
        ++near_threshold;
      }
    }
    EXPECT_EQ(j + near_threshold, expected.size());
    EXPECT_EQ(j, got.size());
  }
}

// Map::Finalize's projection gives a true lower bound on every pair's squared distance:
// |a - mu|^2 >= |P^T a - P^T mu|^2 + (|a - P P^T a| - |mu - P P^T mu|)^2, with P orthonormal;
// on features near landmarks (where the bound is tight) and far from all of them.
TEST(DescriptorSimilarityTest, ProjectionBoundsEveryDistanceFromBelow) {
  Map map = test::MakeRandomMap(20, 600, 5);
  const Eigen::MatrixXf gram = map.local_basis.transpose() * map.local_basis;
  EXPECT_TRUE(gram.isIdentity(1e-4f));
  FeatureSet f = FeaturesNear(map, 200, 9);
  const FeatureSet far = FeaturesNear(test::MakeRandomMap(20, 50, 99), 100, 4);
  f.local.conservativeResize(300, Eigen::NoChange);
  f.local.bottomRows(100) = far.local;
  int tight = 0;
  for (int i = 0; i < f.local.rows(); ++i) {
    const Eigen::VectorXf a = f.local.row(i).transpose();
    const Eigen::VectorXf pa = map.local_basis.transpose() * a;
    const float ra = (a - map.local_basis * pa).norm();
    for (int g = 0; g < map.num_landmarks(); ++g) {
      const float exact = (f.local.row(i) - map.LocalMeanRow(g)).squaredNorm();
      const Eigen::VectorXf pmu = map.local_projected.row(g).transpose();
      const float dr = ra - map.local_residual_norm[g];
      const float bound = (pa - pmu).squaredNorm() + dr * dr;
      ASSERT_LE(bound, exact + 1e-5f) << "feature " << i << ", landmark " << g;
      tight += bound > 0.5f * exact;
    }
  }
  EXPECT_GT(tight, 0);
}

// A feature equal to a landmark's mean has S_D = 1 with it.
TEST(DescriptorSimilarityTest, FeatureAtTheMeanScoresOne) {
  const Map map = test::MakeRandomMap(5, 40, 11);
  FeatureSet f;
  f.image_width = 10;
  f.image_height = 10;
  f.keypoints.resize(1);
  f.local = map.LocalMeanRow(17);
  f.context = map.ContextMeanRow(17);
  EXPECT_FLOAT_EQ(DescriptorSimilarity(f, 0, map, 17), 1.0f);
  const auto matches = ComputeDescriptorMatches(f, map, 0.3f, nullptr);
  bool found = false;
  for (const auto& m : matches) found |= (m.landmark == 17 && m.similarity > 0.999f);
  EXPECT_TRUE(found);
}

}  // namespace
}  // namespace sceneloc
