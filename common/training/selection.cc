#include "common/training/selection.h"

#include <algorithm>
#include <queue>

namespace sceneloc {

std::vector<uint32_t> SelectLandmarks(const std::vector<std::vector<uint32_t>>& landmark_images,
                                      const std::vector<float>& quality, int num_images, int eta,
                                      double q_min) {
  const size_t num_landmarks = landmark_images.size();
  std::vector<uint32_t> selected;
  if (eta == 0) {
    for (size_t g = 0; g < num_landmarks; ++g) {
      if (quality[g] > q_min) selected.push_back(static_cast<uint32_t>(g));
    }
    return selected;
  }
  // Per image, its eligible landmarks by descending quality.
  std::vector<std::vector<uint32_t>> candidates(static_cast<size_t>(num_images));
  for (size_t g = 0; g < num_landmarks; ++g) {
    if (!(quality[g] > q_min)) continue;
    for (uint32_t image : landmark_images[g]) candidates[image].push_back(static_cast<uint32_t>(g));
  }
  for (auto& list : candidates) {
    std::stable_sort(list.begin(), list.end(),
                     [&](uint32_t a, uint32_t b) { return quality[a] > quality[b]; });
  }
  std::vector<int> assigned(static_cast<size_t>(num_images), 0);
  std::vector<size_t> cursor(static_cast<size_t>(num_images), 0);
  std::vector<bool> is_selected(num_landmarks, false);
  // The image with the fewest landmarks assigned (the lowest index among equals) comes from
  // a min-heap of (assigned, image) entries. Counts only grow, so an entry whose count has
  // grown since it was pushed is pushed again with its count, and the first entry that is
  // current is the one a scan of every image would pick: O(log N) a step instead of O(N),
  // which made selection quadratic in the tour.
  using Entry = std::pair<int, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> heap;
  for (int i = 0; i < num_images; ++i) {
    if (!candidates[static_cast<size_t>(i)].empty()) heap.push({0, i});
  }
  while (!heap.empty()) {
    const auto [count, image] = heap.top();
    heap.pop();
    const auto m = static_cast<size_t>(image);
    if (count != assigned[m]) {
      heap.push({assigned[m], image});
      continue;
    }
    if (assigned[m] >= eta) break;
    int wanted = eta - assigned[m];
    while (wanted > 0 && cursor[m] < candidates[m].size()) {
      const uint32_t g = candidates[m][cursor[m]++];
      if (is_selected[g]) continue;
      is_selected[g] = true;
      for (uint32_t i : landmark_images[g]) ++assigned[i];
      --wanted;
    }
    if (cursor[m] < candidates[m].size()) heap.push({assigned[m], image});
  }
  for (size_t g = 0; g < num_landmarks; ++g) {
    if (is_selected[g]) selected.push_back(static_cast<uint32_t>(g));
  }
  return selected;
}

}  // namespace sceneloc
