// Feature tracking (paper II-A): links each tour image's features to the next image's by
// nearest local descriptor within distance t, keeps only the links that are inliers of a
// RANSAC fundamental matrix between the two images, and chains the links into tracks.
#pragma once

#include <cstdint>
#include <vector>

#include "common/features/feature_set.h"
#include "common/map/train_options.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

struct TrackObservation {
  uint32_t image = 0;    // tour image index
  uint32_t feature = 0;  // feature index within that image's FeatureSet
};

// Observations of one real-world point in consecutive tour images, in image order.
using Track = std::vector<TrackObservation>;

struct TrackingStats {
  size_t candidate_links = 0;   // nearest-neighbour links within t, before RANSAC
  size_t verified_links = 0;    // links that are epipolar inliers
  size_t pairs_unverified = 0;  // image pairs with too few links to fit a fundamental matrix
};

// Links of one image pair: next[a] = feature of image i+1 linked to feature a of image i,
// or -1. Exposed for tests.
std::vector<int> LinkImagePair(const FeatureSet& a, const FeatureSet& b,
                               const TrainOptions& options, TrackingStats* stats);

// The links of a whole tour: next[i][a] = the feature of image i + 1 linked to feature a of
// image i, or -1 (LinkImagePair of each consecutive pair).
struct TourLinks {
  std::vector<std::vector<int>> next;  // one per pair: tour size - 1
  std::vector<int> feature_counts;     // features of each tour image
};

// Chains the links into tracks of length >= 2, in order of their first image, then of
// their first feature.
std::vector<Track> ChainTracks(const TourLinks& links);

// Tracks of length >= 2 over a tour in memory (LinkImagePair of each pair, ChainTracks).
// `pool` may be null. Thread-safe.
std::vector<Track> BuildTracks(const std::vector<FeatureSet>& tour, const TrainOptions& options,
                               ThreadPool* pool, TrackingStats* stats);

}  // namespace sceneloc
