// Where a map's places look alike: each tour frame localised against the finished map (the
// shipped matching settings), and of its verified candidates more than kHeldOutFrames away
// the one with the most weighted inliers above chance. On a varied route no such candidate
// verifies; on a street that repeats, the repeat verifies about as well as the frame's own
// place. The map stores each place's look-alikes with the ratio of the two (Map::
// lookalike_*), and the confidence reads their evidence as weaker (confidence.h
// LookAlikeTemperatures); training reports the stretches that look alike ("places 40-48 look
// like 120-128") so the user knows where the map is weak.
//
// Verification is the measure because the frame's own features are in the map: against its
// own place it scores far above any real query, so its posterior says nothing of how sure a
// query would be (a frame held out of its own stretch is "sure" of an unrelated place), but
// a place elsewhere only verifies if it shows the same structure. Within kHeldOutFrames the
// frame shares tracks with its neighbours.
//
// Thread-safety: a function of its arguments; the pool is used for each localisation.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "common/map/map.h"
#include "common/training/tour_features.h"
#include "common/util/status.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

inline constexpr int kHeldOutFrames = 10;
// Weighted inliers above chance a rival needs to be a look-alike: as many again as a wrong
// candidate reaches by chance (MatchOptions::verify_chance_inliers).
inline constexpr float kLookAlikeInliers = 8;

struct LookAlike {
  int32_t rival = -1;  // the location outside the held-out stretch that verifies best (-1: none)
  float excess = 0;    // its weighted inliers above verify_chance_inliers
  float own = 0;       // the same for the best location within the stretch
};

// A run of consecutive tour frames whose rivals run alongside them: places first..last look
// like rival_first..rival_last.
struct LookAlikeStretch {
  int first = 0, last = 0;
  int rival_first = 0, rival_last = 0;
  float excess = 0;  // the most of its frames' rivals' inliers above chance
};

// One LookAlike per tour frame, in tour order; progress(done, total) as frames are measured
// (may be empty). Errors: a tour window that cannot be read, a frame the localiser refuses.
// REQUIRES: `map` was trained from `tour` (one location per frame), Validate()d and
// Finalize()d.
StatusOr<std::vector<LookAlike>> MeasureLookAlikes(
    const TourFeatures& tour, const Map& map, ThreadPool* pool,
    const std::function<void(size_t done, size_t total)>& progress);

// Look-alikes stored in `map` (Map::lookalike_*, replacing any): a frame whose rival verifies
// with at least `min_excess` weighted inliers above chance makes the two places each other's
// look-alike, at the ratio of the rival's excess to the frame's own stretch's (at most 1);
// so are the look-alikes of a place's look-alikes beyond kHeldOutFrames of it (of three
// twins each frame names one), at the product of the two ratios; each place keeps its
// kMaxLookAlikes strongest.
inline constexpr int kMaxLookAlikes = 8;
void StoreLookAlikes(const std::vector<LookAlike>& lookalikes, float min_excess, Map* map);

// The stretches of frames at `min_confidence` or more whose rivals advance with them, either
// way along the route (each next frame's rival within kHeldOutFrames of the last one's, plus
// the frames between), strongest first; one frame below the threshold between two others
// does not break a stretch.
std::vector<LookAlikeStretch> LookAlikeStretches(const std::vector<LookAlike>& lookalikes,
                                                 float min_excess);

}  // namespace sceneloc
