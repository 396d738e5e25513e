#include "common/matching/walks.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/matching/confidence.h"
#include "common/matching/evidence.h"

namespace sceneloc {

std::vector<float> WalkZ(const Map& map, const std::vector<float>& distance,
                         const std::vector<int>* reference) {
  constexpr size_t kMinOwnReference = 20;  // images of its own a walk is read against
  std::vector<float> all;
  if (reference != nullptr) {
    for (const int i : *reference) all.push_back(distance[static_cast<size_t>(i)]);
  }
  const std::vector<float>& pooled = reference != nullptr ? all : distance;
  if (map.experiences.size() < 2 || distance.size() != static_cast<size_t>(map.num_images())) {
    return RobustZ(distance, pooled);  // one walk, or no holistic evidence
  }
  std::vector<float> z(distance.size());
  // The walk of each reference image, for reading each walk against its own.
  std::vector<int> walk_of;
  if (reference != nullptr) {
    walk_of.assign(distance.size(), 0);
    for (size_t e = 0; e < map.experiences.size(); ++e) {
      const Experience& x = map.experiences[e];
      std::fill(walk_of.begin() + x.first_image, walk_of.begin() + x.first_image + x.num_images,
                static_cast<int>(e));
    }
  }
  for (size_t e = 0; e < map.experiences.size(); ++e) {
    const Experience& x = map.experiences[e];
    const std::vector<float> values(distance.begin() + x.first_image,
                                    distance.begin() + x.first_image + x.num_images);
    std::vector<float> own;
    if (reference != nullptr) {
      for (const int i : *reference) {
        if (walk_of[static_cast<size_t>(i)] == static_cast<int>(e)) {
          own.push_back(distance[static_cast<size_t>(i)]);
        }
      }
    }
    const std::vector<float>& own_reference = reference != nullptr ? own : values;
    const std::vector<float> walk =
        RobustZ(values, own_reference.size() >= kMinOwnReference ? own_reference : pooled);
    std::copy(walk.begin(), walk.end(), z.begin() + x.first_image);
  }
  return z;
}

void WeighByWalk(const Map& map, const std::vector<float>& distance, std::vector<float>* z) {
  constexpr double kWalkFloor = 1e-4;  // the least weight a walk keeps
  if (map.experiences.size() < 2 || distance.size() != static_cast<size_t>(map.num_images())) {
    return;
  }
  for (const Experience& x : map.experiences) {
    if (!x.calibration.valid) return;
  }
  const double t = map.options.confidence_temperature;
  for (const Experience& x : map.experiences) {
    const auto begin = distance.begin() + x.first_image;
    const float nearest = *std::min_element(begin, begin + x.num_images);
    const double p = std::max(kWalkFloor, InMapProbability(map, x.calibration, nearest));
    const auto weight = static_cast<float>(t * std::log(p));
    for (uint32_t i = x.first_image; i < x.first_image + x.num_images; ++i) (*z)[i] += weight;
  }
}

void PoolPlaces(const Map& map, const MatchOptions& options,
                std::vector<CandidateEvidence>* candidates) {
  for (CandidateEvidence& c : *candidates) c.image = c.location;
  if (map.image_place.empty()) return;
  std::vector<int> kept(static_cast<size_t>(map.num_places()), -1);
  std::vector<CandidateEvidence> pooled;
  for (CandidateEvidence& c : *candidates) {
    c.location = map.PlaceOf(c.image);
    int& k = kept[static_cast<size_t>(c.location)];
    if (k < 0) {
      k = static_cast<int>(pooled.size());
      pooled.push_back(c);
    } else if (FuseEvidence(c, options) > FuseEvidence(pooled[static_cast<size_t>(k)], options)) {
      pooled[static_cast<size_t>(k)] = c;
    }
  }
  *candidates = std::move(pooled);
}

std::vector<float> PlaceMaxima(const Map& map, const std::vector<float>& values) {
  if (map.image_place.empty() || values.empty()) return values;
  std::vector<float> out(static_cast<size_t>(map.num_places()),
                         -std::numeric_limits<float>::infinity());
  for (size_t i = 0; i < values.size(); ++i) {
    float& v = out[map.image_place[i]];
    v = std::max(v, values[i]);
  }
  return out;
}

}  // namespace sceneloc
