// Maps that grow by walks (experiences): a walk added to a trained map without retraining it.
//
//   the walk's features -> localised against the map as a session (both ways along it):
//   each frame's place -> frames the map already recognises add nothing -> the rest are
//   trained as a tour of their own (tracks, landmarks, Q, eta selection, co-occurrence)
//   -> their images and landmarks are appended to the map, each image showing its place.
//
// Frames the session leaves unplaced between two it placed are placed along the walk at the
// pace between them.
//
// A walk of the route under other conditions (night, another side of the path) becomes a
// new experience of the places it passes (ExperienceKind::kRoute): the map then shows those
// places in more than one image, and the localiser answers with the place (localiser.h).
// A walk of new ground becomes new places after the map's (kNewGround). Alignment never
// reads file names. Training the walk costs what training a map of its frames costs; the
// merge is linear in the walk and copies the map once.
//
// Thread-compatible; ExtendMap uses `threads` workers of its own.
#pragma once

#include <string>
#include <vector>

#include "common/map/map.h"
#include "common/matching/localiser.h"
#include "common/training/tour_features.h"
#include "common/training/trainer.h"
#include "common/util/status.h"

namespace sceneloc {

struct ExtendOptions {
  std::string name;        // the experience's name (e.g. the walk's folder name)
  std::string source_dir;  // where the walk came from, as recorded in the map
  // Every frame a new place (ExperienceKind::kNewGround) instead of aligning the walk.
  bool new_ground = false;
  // A frame is recognised, and adds nothing, when the map explains it nearly as well as the
  // walk's next frame does: its single-frame answer is LOCALISED at least
  // recognised_confidence sure, agrees with the session within the map's tolerance, and
  // verifies with at least recognised_inlier_share of the epipolar links the walk's
  // consecutive frames share (their mean). Confidence alone would drop a view from the
  // other side of the path, which the map recognises but which another light needs.
  double recognised_confidence = 0.95;
  double recognised_inlier_share = 0.4;
  // A walk of the route must have at least this share of its frames aligned (the session
  // LOCALISED in one direction or the other), else it is refused as an experience.
  double min_aligned_share = 0.5;
  // How the walk's frames are localised against the map (shipped matching settings).
  MatchOptions match;
};

// What became of one frame of the walk.
struct WalkFrame {
  int place = -1;          // the place it was aligned to (-1: none; new ground: its new place)
  double probability = 0;  // the session's probability for that place
  int single = -1;         // the single-frame answer
  double single_confidence = 0;  // its confidence when LOCALISED, else 0
  int single_inliers = 0;        // the single-frame answer's verified inliers
  bool bridged = false;          // placed along the walk between frames the session placed
  bool recognised = false;       // the map knew it: added nothing
  bool added = false;            // its image and landmarks were added
};

struct ExtendSummary {
  std::vector<WalkFrame> frames;  // one per walk frame, in walk order
  size_t aligned = 0;             // frames the session placed
  size_t bridged = 0;             // frames placed between them (BridgeGaps)
  size_t recognised = 0;          // of those, frames that added nothing
  double recognised_inliers = 0;  // the inliers that recognised a frame (with the confidence)
  size_t added = 0;               // images added
  size_t new_places = 0;          // places added (new ground)
  size_t landmarks_added = 0;
  TrainSummary walk;  // training the walk's frames as a tour of their own
  double align_seconds = 0;
  double train_seconds = 0;
  double merge_seconds = 0;
};

struct ExtendResult {
  Map map;
  ExtendSummary summary;
};

// Adds the walk `walk` (features in the map's working frame, Map::QueryTarget; names[i]
// names frame i) to `map`. Errors: fewer than 2 frames, a frame in another working frame
// width (FailedPrecondition), a route walk that aligns too little of itself
// (FailedPrecondition, saying how much and that it can be added as new ground), a walk in
// which nothing is left to add (FailedPrecondition), and the training's errors.
// REQUIRES: map Validate()d and Finalize()d.
StatusOr<ExtendResult> ExtendMap(const Map& map, const TourFeatures& walk,
                                 const std::vector<std::string>& names,
                                 const ExtendOptions& options, int threads,
                                 const ProgressFn& progress);

}  // namespace sceneloc
