// Landmark quality Q (paper IV, eq. 4): the expected true-positive over false-positive
// similarity mass of a landmark over every feature of the training tour.
//
//   Q(g_j) = sum_{f in G_j} p(g_j|f) S_D(f, g_j) / (prior + sum_{f not in G_j} p(g_j|f) S_D(f,
//   g_j)) p(g_j|f) = S_D(f, g_j) / sum_k S_D(f, g_k)   over the landmarks with S_D >= s_min
//
// "f in G_j" means f is one of the features the landmark was fused from. The prior
// (TrainOptions::quality_fp_prior) is our rule for the zero denominator; see there.
#pragma once

#include <functional>
#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/training/tour_features.h"
#include "common/training/tracker.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

// Returns Q per landmark of `candidates` (landmark j was fused from tracks[j]) over the
// features of every image `tour` holds: the whole tour (the paper), or the window of the
// tour around the candidates that sceneloc-train scores them in (TrainOptions::
// quality_window). `progress(done, total)` is called as images are done, from the calling
// thread only. REQUIRES: candidates.Finalize() was called; the window holds every
// observation of every track.
std::vector<float> ComputeQuality(const Map& candidates, const std::vector<Track>& tracks,
                                  const TourWindow& tour, double s_min, double fp_prior,
                                  ThreadPool* pool,
                                  const std::function<void(size_t, size_t)>& progress);

}  // namespace sceneloc
