// The landmark candidates of a tour, in chunks of consecutive tour images, so that the
// candidates can be fused and scored a chunk at a time (trainer.h).
//
// A candidate belongs to the chunk of its first image: the tracks that start there, then
// the single-view candidates of the chunk's images (coverage, or every untracked feature
// with min_track_length 1). Each chunk's features are read as one window of the tour, from
// its first image to the last image any of its candidates was seen in. Quality Q (eq. 4) is
// measured over that window: against the window's features and among the chunk's
// candidates. With one chunk for the whole tour (a tour no longer than
// TrainOptions::quality_window, or a window of 0) this is the paper's Q over the whole tour,
// and the candidates come in the order they always have.
//
// Thread-compatible: plain data and functions of their arguments.
#pragma once

#include <cstdint>
#include <vector>

#include "common/map/map.h"
#include "common/training/tour_features.h"
#include "common/training/tracker.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

struct CandidateChunk {
  size_t begin = 0;  // its images: [begin, end)
  size_t end = 0;
  // Its candidates: the tracks that start in [begin, end), in ChainTracks order, then (once
  // AddSingleViewCandidates ran) the single-view ones, image by image.
  std::vector<Track> tracks;
  size_t first_candidate = 0;  // global index of tracks[0] among every chunk's candidates
  // The images holding every observation of its candidates: [begin, window_end()).
  size_t window_end() const;
};

// Which features of each image some kept track holds.
struct TrackedFeatures {
  std::vector<std::vector<bool>> tracked;  // [image][feature]
  std::vector<int> count;                  // tracked features per image
};

// Splits `tracks` (ChainTracks order: by first image) into chunks of `window` images (0: one
// chunk for the whole tour of `num_images`), after dropping tracks shorter than
// min_track_length. Fills `tracked` from the tracks kept.
std::vector<CandidateChunk> PlanChunks(std::vector<Track> tracks, const TourLinks& links,
                                       int min_track_length, int window, TrackedFeatures* tracked);

// Adds the chunk's single-view candidates from its window of features: every untracked
// feature of its images when min_track_length is 1; else, for each of its images with
// fewer than min_landmarks_per_image tracked features, its strongest untracked features up to
// that many. Returns how many it added. REQUIRES: the window holds [chunk.begin, chunk.end).
size_t AddSingleViewCandidates(const TourWindow& window, const TrackedFeatures& tracked,
                               const TrainOptions& options, CandidateChunk* chunk);

// A map of `tracks` fused from the window's features, with observations and image lists,
// validated and finalised (ready for ComputeDescriptorMatches); quality zero, no
// neighbours, no holistic descriptors.
StatusOr<Map> FuseCandidates(const std::vector<Track>& tracks, const TourWindow& window,
                             const std::vector<std::string>& image_names, int frame_width,
                             int frame_height, const TrainOptions& options);

// Makes room in `map` for `count` landmarks, none in yet (AppendLandmarks fills them).
void ReserveLandmarks(size_t count, Map* map);

// Appends the landmarks (arrays and observations) of `part` to `map`. REQUIRES:
// ReserveLandmarks left room for them.
void AppendLandmarks(const Map& part, Map* map);

}  // namespace sceneloc
