// Feature extraction: SIFT keypoints with a local and a context descriptor each, and a
// holistic descriptor of the whole frame (holistic.h). The one extractor used by training,
// evaluation, the server and the client, so a map and the frames matched against it always
// see the same features.
//
// The working frame. Every image is resized (down or up) to a frame of known size before
// anything is extracted, so that what a map learns in pixels means the same for every query:
//   - a tour image goes to its *tour frame*: long side = working_size (TourTarget);
//   - a query goes to the frame of the map it is matched against, scaled uniformly so its
//     width is the map frame's width (MapTarget in common/map/map.h), whatever camera or
//     resolution it came from.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "common/features/feature_set.h"
#include "common/features/holistic.h"
#include "common/util/status.h"

namespace sceneloc {

// Small images are enlarged by at most this factor to reach their working frame (a 160x120
// frame reaches 480x360; a 40x30 one stops at 160x120).
inline constexpr double kMaxUpscale = 4.0;

struct ExtractorOptions {
  // Keep at most this many keypoints per image, strongest response first. 0 = no cap.
  int max_features = 1000;
  // Long side of a tour's working frame, pixels: 960x540 tours work at 480x270, 160x120
  // ones at 480x360 (enlarged: SIFT finds few features in tiny frames). Every pixel-unit
  // setting of a map is relative to this frame.
  int working_size = 480;
  // The context descriptor is computed at this multiple of the keypoint size (paper: 2).
  double context_scale = 2.0;
  // SIFT detector settings (OpenCV's defaults). A lower contrast threshold (0.02, 0.01) keeps
  // more features in dark frames but measured no better once the holistic descriptor
  // answers those, at a third more matching time (docs/results.md).
  double contrast_threshold = 0.04;
  double edge_threshold = 10.0;
  double sigma = 1.6;
  // Scale levels per pyramid octave (OpenCV's default and Lowe's). It shapes which keypoints
  // are found and where a context descriptor is read (one octave up = this many layers), so
  // a map stores it and every query is extracted with the map's.
  int octave_layers = 3;
  // Refuse images larger than this many pixels per side (untrusted input).
  int max_image_side = kDefaultMaxImageSide;
  // Lighting options, measured and off by default (docs/results.md): contrast-limited
  // adaptive histogram equalisation of the working frame before SIFT, with this clip limit
  // (0 = off); RootSIFT descriptors instead of SIFT's.
  double clahe_clip = 0;
  bool root_sift = false;
  // The holistic descriptor (holistic.h); holistic.cols = 0 turns it off.
  HolisticOptions holistic;

  // The ranges of ExtractorSettings, and the holistic descriptor's own rule.
  Status Validate() const;
};

// The fields of `o` as settings under `section` (training files: extractor:), with the
// holistic descriptor's.
SettingTable ExtractorSettings(ExtractorOptions* o, const std::string& section = "extractor");

// Where one image is extracted: the frame it is resized to and the holistic grid.
struct ExtractionTarget {
  int width = 0;  // working frame, pixels
  int height = 0;
  HolisticGrid holistic;  // empty: no holistic descriptor
};

// The tour frame of an image of `width` x `height`: long side = working_size (enlarged at
// most kMaxUpscale times). REQUIRES: width, height > 0.
ExtractionTarget TourTarget(int width, int height, const ExtractorOptions& options);

// The frame of a query of `width` x `height` matched against a map whose working frame is
// `map_width` wide: the same uniform scale brings the query's width to map_width, and the
// holistic descriptor uses the map's grid. REQUIRES: all sizes > 0.
ExtractionTarget QueryTarget(int width, int height, int map_width, const HolisticGrid& map_grid);

// Thread-safe: Extract() may be called from several threads at once.
class FeatureExtractor {
 public:
  virtual ~FeatureExtractor() = default;
  static std::unique_ptr<FeatureExtractor> Create(const ExtractorOptions& options);

  // Extracts features from a decoded image (8-bit, 1, 3 or 4 channels, at any size) in
  // `target`. Errors: an empty, non-8-bit, too large (max_image_side) or too small
  // (kMinImageSide) image, or a target frame below kMinImageSide.
  virtual StatusOr<FeatureSet> Extract(const cv::Mat& image,
                                       const ExtractionTarget& target) const = 0;
  // The same in the image's own tour frame (TourTarget).
  StatusOr<FeatureSet> ExtractTour(const cv::Mat& image) const;
  virtual const ExtractorOptions& options() const = 0;
};

// The context keypoint of each of `set`'s keypoints: the same point at context_scale times
// its size, with OpenCV's KeyPoint::octave packing the pyramid octave and layer that its
// context descriptor is read from (extractor.cc, ContextKeypoint). Extract describes these;
// exposed for benchmarks and tests.
std::vector<cv::KeyPoint> ContextKeypoints(const FeatureSet& set, const ExtractorOptions& options);

// Reads an image file; a missing, unreadable or non-image file is an error naming it.
StatusOr<cv::Mat> ReadImageFile(const std::string& path);
// Decodes JPEG/PNG bytes; corrupt bytes are an error, never an exception.
StatusOr<cv::Mat> DecodeImage(const std::string& bytes, int max_image_side);

// The largest factor (1, 2, 4 or 8) by which an image of `width` x `height` can be decoded
// smaller and still be at least `target` on both sides, so that the extractor only ever
// shrinks it. REQUIRES: all sizes > 0.
int DecodeReduction(int width, int height, const ExtractionTarget& target);

// Decodes JPEG/PNG bytes straight to grey at 1/reduction of their size (1, 2, 4 or 8):
// for a JPEG, libjpeg's DCT scaling skips most of the inverse transform and the colour
// conversion (a 960x540 frame to its 480x270 working frame: 0.7 against 1.6 ms, issue
// 10). What the extractor does next (resize to the target, SIFT on grey) is unchanged.
// Errors as DecodeImage; max_image_side applies to the decoded image.
StatusOr<cv::Mat> DecodeGray(const std::string& bytes, int max_image_side, int reduction);

}  // namespace sceneloc
