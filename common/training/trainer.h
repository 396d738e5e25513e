// sceneloc-train's engine: tour images in, landmark map out.
//   features -> tracks -> landmarks -> quality Q -> eta selection -> co-occurrence
//
// Training streams the tour: its features are read a window of consecutive images at a
// time (tour_features.h; sceneloc-train spools them to disk as they are extracted), and
// the landmark candidates are fused and scored chunk by chunk (TrainOptions::
// quality_window), so time and memory grow with the tour's length, not its square. A tour
// no longer than one window trains exactly as the paper's single pass over the whole tour.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/training/lookalikes.h"
#include "common/training/tour_features.h"
#include "common/util/status.h"

namespace sceneloc {

// Called as work progresses: stage name, items done, items in the stage. Stages, in order:
// "extract" (images; folders only), "link" (image pairs), "quality" (images scored),
// "fuse" (images), "look-alikes" (images).
using ProgressFn = std::function<void(const std::string& stage, size_t done, size_t total)>;

struct TrainSummary {
  size_t images = 0;
  int frame_width = 0;  // the map's working frame
  int frame_height = 0;
  size_t mixed_size_images = 0;  // tour images whose size differs from the first's
  size_t features = 0;
  size_t candidate_links = 0;
  size_t verified_links = 0;
  size_t tracks = 0;              // landmark candidates: tracks of at least min_track_length images
  size_t coverage_landmarks = 0;  // single-view candidates added by min_landmarks_per_image
  double mean_track_length = 0;
  size_t max_track_length = 0;
  size_t landmarks_before_selection = 0;
  size_t landmarks_kept = 0;
  double landmarks_per_image_mean = 0;
  size_t landmarks_per_image_min = 0;
  size_t landmarks_per_image_max = 0;
  size_t quality_windows = 0;  // chunks the candidates were scored in (1: the whole tour)
  uint64_t spool_bytes = 0;    // features spooled to disk (0: the tour was in memory)
  // Tour images left with no landmark: only the holistic descriptor can answer them.
  std::vector<std::string> images_without_landmarks;
  // Per tour image, the place that wins with its own stretch held out (lookalikes.h).
  std::vector<LookAlike> lookalikes;
  // Wall-clock seconds per step.
  double extract_seconds = 0;
  double track_seconds = 0;
  double fuse_seconds = 0;
  double quality_seconds = 0;
  double select_seconds = 0;
  double cooccurrence_seconds = 0;
  double calibration_seconds = 0;
  double index_seconds = 0;  // the place index (place_index_builder.h)
  double lookalike_seconds = 0;
};

struct TrainResult {
  Map map;
  TrainSummary summary;
};

// Now, as ISO 8601 UTC ("2026-12-07T21:26:17Z"): when a map or an experience was made.
std::string UtcNow();

// Where each image is extracted, given its size.
using TargetFn = std::function<ExtractionTarget(int width, int height)>;

// Extracts the features of every image in `image_paths` (in order), `threads` at a time,
// each in target(width, height). The first image that cannot be read or extracted fails
// the whole call, naming the file. `mixed_sizes`, when not null, receives the number of
// images whose size differs from the first one's. Holds every image's features: for long
// tours, ExtractToSpool.
StatusOr<std::vector<FeatureSet>> ExtractImages(const std::vector<std::string>& image_paths,
                                                const ExtractorOptions& options,
                                                const TargetFn& target, int threads,
                                                const ProgressFn& progress,
                                                size_t* mixed_sizes = nullptr);

// ExtractImages for a tour: every image in the tour frame of the first (TourTarget); an
// image of another size is brought into that frame as a query would be.
StatusOr<std::vector<FeatureSet>> ExtractFolder(const std::vector<std::string>& image_paths,
                                                const ExtractorOptions& options, int threads,
                                                const ProgressFn& progress,
                                                size_t* mixed_sizes = nullptr);

// ExtractImages into `spool`, in order, holding only a few images' features at a time.
Status ExtractToSpool(const std::vector<std::string>& image_paths, const ExtractorOptions& options,
                      const TargetFn& target, int threads, const ProgressFn& progress,
                      FeatureSpool* spool);

// ExtractFolder into `spool`, in order, holding only a few images' features at a time.
Status ExtractToSpool(const std::vector<std::string>& image_paths, const ExtractorOptions& options,
                      int threads, const ProgressFn& progress, FeatureSpool* spool,
                      size_t* mixed_sizes = nullptr);

// Trains from a tour's features, read a window at a time. image_names[i] names image i.
// `lookalikes` false skips measuring the map's look-alikes (a walk trained to extend a map,
// extend.h, is measured there instead).
StatusOr<TrainResult> TrainFromTour(const TourFeatures& tour,
                                    const std::vector<std::string>& image_names,
                                    const TrainOptions& options, int threads,
                                    const ProgressFn& progress, bool lookalikes = true);

// Trains from already extracted tour features. image_names[i] names tour[i].
StatusOr<TrainResult> TrainFromFeatures(const std::vector<FeatureSet>& tour,
                                        const std::vector<std::string>& image_names,
                                        const TrainOptions& options, int threads,
                                        const ProgressFn& progress);

// Lists, extracts (spooling the features in `spool_dir`, "" for the system's temporary
// folder) and trains. Errors: a bad folder, an unreadable image (named), fewer than 2
// images, invalid options, a spool that cannot be written (a full disk).
StatusOr<TrainResult> TrainFromFolder(const std::string& tour_dir, const TrainOptions& options,
                                      int threads, const ProgressFn& progress,
                                      const std::string& spool_dir = "");

}  // namespace sceneloc
