#include "common/training/selection.h"

#include <gtest/gtest.h>

#include <random>

namespace sceneloc {
namespace {

// The paper's iterative algorithm on a hand-made case: 3 images, eta = 2.
//   g0 (Q 0.9) images 0,1   g1 (Q 0.8) image 0    g2 (Q 0.7) images 1,2
//   g3 (Q 0.6) image 2      g4 (Q 0.5) image 2    g5 (Q 0.005) image 2 (below q_min)
// Round 1: I_min = image 0 (0 assigned): take g0, g1 -> counts 2,1,0.
// Round 2: I_min = image 2: take g2, g3 -> counts 2,2,2. Stop. g4, g5 never selected.
TEST(SelectionTest, HandComputedIterations) {
  const std::vector<std::vector<uint32_t>> images = {{0, 1}, {0}, {1, 2}, {2}, {2}, {2}};
  const std::vector<float> q = {0.9f, 0.8f, 0.7f, 0.6f, 0.5f, 0.005f};
  EXPECT_EQ(SelectLandmarks(images, q, 3, 2, 0.01), (std::vector<uint32_t>{0, 1, 2, 3}));
}

// q_min is a hard floor even when an image stays below eta; the loop still ends.
TEST(SelectionTest, QminFloorAndExhaustedImages) {
  const std::vector<std::vector<uint32_t>> images = {{0}, {1}, {1}};
  const std::vector<float> q = {0.5f, 0.009f, 0.2f};
  EXPECT_EQ(SelectLandmarks(images, q, 2, 5, 0.01), (std::vector<uint32_t>{0, 2}));
}

// eta = 0 keeps every landmark above q_min.
TEST(SelectionTest, EtaZeroKeepsAllAboveQmin) {
  const std::vector<std::vector<uint32_t>> images = {{0}, {0}, {1}};
  const std::vector<float> q = {0.5f, 0.001f, 0.02f};
  EXPECT_EQ(SelectLandmarks(images, q, 2, 0, 0.01), (std::vector<uint32_t>{0, 2}));
}

// The paper's algorithm as written: each round scans every image for the one with the fewest
// landmarks assigned (the lowest index among equals). SelectLandmarks finds it with a heap.
std::vector<uint32_t> ScanningSelection(const std::vector<std::vector<uint32_t>>& landmark_images,
                                        const std::vector<float>& quality, int num_images, int eta,
                                        double q_min) {
  std::vector<std::vector<uint32_t>> candidates(static_cast<size_t>(num_images));
  for (size_t g = 0; g < landmark_images.size(); ++g) {
    if (!(quality[g] > q_min)) continue;
    for (uint32_t image : landmark_images[g]) candidates[image].push_back(static_cast<uint32_t>(g));
  }
  for (auto& list : candidates) {
    std::stable_sort(list.begin(), list.end(),
                     [&](uint32_t a, uint32_t b) { return quality[a] > quality[b]; });
  }
  std::vector<int> assigned(static_cast<size_t>(num_images), 0);
  std::vector<size_t> cursor(static_cast<size_t>(num_images), 0);
  std::vector<bool> selected(landmark_images.size(), false), exhausted(assigned.size(), false);
  for (;;) {
    int m = -1;
    for (int i = 0; i < num_images; ++i) {
      if (!exhausted[i] && (m < 0 || assigned[i] < assigned[m])) m = i;
    }
    if (m < 0 || assigned[m] >= eta) break;
    for (int wanted = eta - assigned[m]; wanted > 0 && cursor[m] < candidates[m].size();) {
      const uint32_t g = candidates[m][cursor[m]++];
      if (selected[g]) continue;
      selected[g] = true;
      for (uint32_t image : landmark_images[g]) ++assigned[image];
      --wanted;
    }
    if (cursor[m] >= candidates[m].size()) exhausted[m] = true;
  }
  std::vector<uint32_t> out;
  for (size_t g = 0; g < selected.size(); ++g) {
    if (selected[g]) out.push_back(static_cast<uint32_t>(g));
  }
  return out;
}

// On random tours (tracks of 1-6 consecutive images, qualities with ties and some below
// q_min, images left without candidates) the heap picks exactly what the scan picks.
TEST(SelectionTest, SameAsScanningEveryImageEachRound) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 50; ++trial) {
    const int num_images = 1 + static_cast<int>(rng() % 40);
    const int eta = 1 + static_cast<int>(rng() % 12);  // 0 keeps all: no rounds
    std::vector<std::vector<uint32_t>> images;
    std::vector<float> quality;
    const int landmarks = static_cast<int>(rng() % 400);
    for (int g = 0; g < landmarks; ++g) {
      const int first = static_cast<int>(rng() % num_images);
      const int length = std::min(num_images - first, 1 + static_cast<int>(rng() % 6));
      std::vector<uint32_t> seen;
      for (int i = first; i < first + length; ++i) seen.push_back(static_cast<uint32_t>(i));
      images.push_back(seen);
      quality.push_back(static_cast<float>(rng() % 20) / 10.0f);  // ties; 0 is below q_min
    }
    SCOPED_TRACE("trial " + std::to_string(trial));
    EXPECT_EQ(SelectLandmarks(images, quality, num_images, eta, 0.01),
              ScanningSelection(images, quality, num_images, eta, 0.01));
  }
}

}  // namespace
}  // namespace sceneloc
