#include "common/training/tracker.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

namespace sceneloc {
namespace {

// Three views of one random 3-D point cloud from a camera moving sideways. Point k has
// the same (slightly noisy) descriptor in every view; the last `outliers` features of
// each view have descriptors of their own, shared across views, at a random position in
// each (a descriptor match that RANSAC must reject).
std::vector<FeatureSet> ThreeViews(int points, int outliers, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1, 1);
  std::normal_distribution<float> noise(0, 0.01f);
  std::vector<Eigen::Vector3f> cloud(points);
  for (auto& p : cloud) p = {4 * u(rng), 2 * u(rng), 8 + 3 * u(rng)};
  DescriptorMatrix base(points + outliers, kDescriptorSize);
  for (int k = 0; k < points + outliers; ++k) {
    for (int c = 0; c < kDescriptorSize; ++c) base(k, c) = std::abs(u(rng));
    base.row(k).normalize();
  }
  std::vector<FeatureSet> views(3);
  for (int v = 0; v < 3; ++v) {
    FeatureSet& f = views[v];
    f.image_width = 640;
    f.image_height = 360;
    const Eigen::Matrix3f r = Eigen::AngleAxisf(0.03f * v, Eigen::Vector3f::UnitY()).matrix();
    const Eigen::Vector3f t(-0.4f * v, 0.05f * v, 0);
    f.local.resize(points + outliers, kDescriptorSize);
    for (int k = 0; k < points + outliers; ++k) {
      Keypoint kp{320 + 300 * u(rng), 180 + 170 * u(rng), 4, 0, 1, 0};
      if (k < points) {
        const Eigen::Vector3f c = r * cloud[k] + t;
        kp = {320 + 500 * c.x() / c.z(), 180 + 500 * c.y() / c.z(), 4, 0, 1, 0};
      }
      f.keypoints.push_back(kp);
      for (int d = 0; d < kDescriptorSize; ++d) f.local(k, d) = base(k, d) + noise(rng);
      f.local.row(k).normalize();
    }
    f.context = f.local;
  }
  return views;
}

// Epipolar verification keeps the true links and drops the planted wrong ones.
TEST(TrackerTest, RansacKeepsTrueLinksAndDropsOutliers) {
  const auto views = ThreeViews(200, 30, 4);
  TrainOptions options;
  TrackingStats stats;
  const std::vector<int> next = LinkImagePair(views[0], views[1], options, &stats);
  int true_links = 0, wrong_links = 0;
  for (int k = 0; k < static_cast<int>(next.size()); ++k) {
    if (next[k] < 0) continue;
    if (k < 200 && next[k] == k) {
      ++true_links;
    } else {
      ++wrong_links;
    }
  }
  EXPECT_GE(true_links, 190);
  EXPECT_LE(wrong_links, 3);
  EXPECT_GT(stats.candidate_links, stats.verified_links);
}

// Links chain into tracks across images: most points become one track of length 3.
TEST(TrackerTest, ChainsLinksIntoTracks) {
  const auto views = ThreeViews(150, 0, 5);
  TrainOptions options;
  TrackingStats stats;
  ThreadPool pool(2);
  const auto tracks = BuildTracks(views, options, &pool, &stats);
  int full = 0;
  for (const Track& t : tracks) {
    ASSERT_GE(t.size(), 2u);
    for (size_t i = 1; i < t.size(); ++i) EXPECT_EQ(t[i].image, t[i - 1].image + 1);
    if (t.size() == 3 && t[0].feature == t[1].feature && t[1].feature == t[2].feature) ++full;
  }
  EXPECT_GE(full, 140);
}

// Descriptors further apart than t are never linked.
TEST(TrackerTest, DistanceThresholdIsRespected) {
  auto views = ThreeViews(100, 0, 6);
  TrainOptions options;
  options.track_distance_threshold = 0.001;  // tighter than the descriptor noise
  TrackingStats stats;
  const std::vector<int> next = LinkImagePair(views[0], views[1], options, &stats);
  EXPECT_EQ(stats.candidate_links, 0u);
  for (int n : next) EXPECT_EQ(n, -1);
}

}  // namespace
}  // namespace sceneloc
