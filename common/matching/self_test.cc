#include "common/matching/self_test.h"

#include <algorithm>
#include <cstdint>
#include <string>

namespace sceneloc {
namespace {

// The self-test query of one location uses at most this many landmarks (enough to
// exercise every stage; more only costs load time).
constexpr int kSelfTestMaxFeatures = 1500;

}  // namespace

FeatureSet SelfTestFeatures(const Map& map, int location) {
  const uint32_t begin = map.image_offsets[static_cast<size_t>(location)];
  const uint32_t end = map.image_offsets[static_cast<size_t>(location) + 1];
  const int n = std::min(static_cast<int>(end - begin), kSelfTestMaxFeatures);
  FeatureSet f;
  f.image_width = map.image_width;
  f.image_height = map.image_height;
  f.keypoints.resize(static_cast<size_t>(n));
  f.local.resize(n, kDescriptorSize);
  f.context.resize(n, kDescriptorSize);
  for (int i = 0; i < n; ++i) {
    const uint32_t g = map.image_landmarks[begin + static_cast<uint32_t>(i)];
    Keypoint& k = f.keypoints[static_cast<size_t>(i)];
    const auto [x, y] = map.MeanPosition(static_cast<int>(g));
    k.x = x;
    k.y = y;
    k.size = 8.0f;
    // Where and how large g was seen in this very image (G_l holds only landmarks seen in
    // l), so verification's epipolar and scale checks see the location as it was.
    for (uint32_t o = map.observation_offsets[g]; o < map.observation_offsets[g + 1]; ++o) {
      if (map.observation_image[o] == static_cast<uint32_t>(location)) {
        k.x = map.ObservationX(o);
        k.y = map.ObservationY(o);
        k.size = map.ObservationSize(o);
        break;
      }
    }
    k.response = 1.0f;
    map.LocalMean(static_cast<int>(g), f.local.row(i).data());
    map.ContextMean(static_cast<int>(g), f.context.row(i).data());
  }
  NormaliseRows(&f.local);
  NormaliseRows(&f.context);
  return f;
}

Status SelfTestMap(const Map& map, const MatchOptions& options, int probes) {
  const int images = map.num_images();
  probes = std::min(probes, images);
  for (int p = 0; p < probes; ++p) {
    // Spread the probes over the tour: first, last, and evenly between.
    const int location = probes == 1 ? images / 2 : p * (images - 1) / (probes - 1);
    auto result = Localise(SelfTestFeatures(map, location), map, options, nullptr);
    if (!result.ok()) {
      return FailedPrecondition("self-test query of location " + std::to_string(location) +
                                " failed: " + result.status().message());
    }
    const auto& ranked = result->ranked;
    const bool found = std::any_of(ranked.begin(), ranked.end(),
                                   [&](const RankedLocation& r) { return r.index == location; });
    if (!found) {
      return FailedPrecondition(
          "self-test: location " + std::to_string(location) +
          "'s own landmarks do not rank it among the best " + std::to_string(ranked.size()) +
          (ranked.empty() ? "" : " (best: " + std::to_string(ranked[0].index) + ")"));
    }
  }
  return Status::Ok();
}

}  // namespace sceneloc
