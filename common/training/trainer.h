// sceneloc-train's engine: tour images in, landmark map out.
//   features -> tracks -> landmarks -> quality Q -> eta selection -> co-occurrence
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/util/status.h"

namespace sceneloc {

// Called as work progresses: stage name, items done, items in the stage.
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
  // Tour images left with no landmark: only the holistic descriptor can answer them.
  std::vector<std::string> images_without_landmarks;
  // Wall-clock seconds per step.
  double extract_seconds = 0;
  double track_seconds = 0;
  double fuse_seconds = 0;
  double quality_seconds = 0;
  double select_seconds = 0;
  double cooccurrence_seconds = 0;
  double calibration_seconds = 0;
};

struct TrainResult {
  Map map;
  TrainSummary summary;
};

// Where each image is extracted, given its size.
using TargetFn = std::function<ExtractionTarget(int width, int height)>;

// Extracts the features of every image in `image_paths` (in order), `threads` at a time,
// each in target(width, height). The first image that cannot be read or extracted fails
// the whole call, naming the file. `mixed_sizes`, when not null, receives the number of
// images whose size differs from the first one's.
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

// Trains from already extracted tour features. image_names[i] names tour[i].
StatusOr<TrainResult> TrainFromFeatures(const std::vector<FeatureSet>& tour,
                                        const std::vector<std::string>& image_names,
                                        const TrainOptions& options, int threads,
                                        const ProgressFn& progress);

// Lists, extracts and trains. Errors: a bad folder, an unreadable image (named), fewer
// than 2 images, invalid options.
StatusOr<TrainResult> TrainFromFolder(const std::string& tour_dir, const TrainOptions& options,
                                      int threads, const ProgressFn& progress);

}  // namespace sceneloc
