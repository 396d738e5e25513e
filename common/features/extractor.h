// Feature extraction: SIFT keypoints with a local and a context descriptor each.
// The one extractor used by training, evaluation and the server, so a map and the
// frames matched against it always see the same features.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "common/features/feature_set.h"
#include "common/util/status.h"

namespace sceneloc {

struct ExtractorOptions {
  // Keep at most this many keypoints per image, strongest response first. 0 = no cap.
  int max_features = 1000;
  // Resize every image by this factor before extraction (0 < s <= 1). 0.5 turns a
  // 960x540 frame into 480x270. Keypoint coordinates are in the resized frame.
  double image_scale = 0.5;
  // The context descriptor is computed at this multiple of the keypoint size (paper: 2).
  double context_scale = 2.0;
  // SIFT detector settings (OpenCV defaults).
  double contrast_threshold = 0.04;
  double edge_threshold = 10.0;
  double sigma = 1.6;
  // Refuse images larger than this many pixels per side (untrusted input).
  int max_image_side = 8192;

  Status Validate() const;
};

// Thread-safe: Extract() may be called from several threads at once.
class FeatureExtractor {
 public:
  virtual ~FeatureExtractor() = default;
  static std::unique_ptr<FeatureExtractor> Create(const ExtractorOptions& options);

  // Extracts features from a decoded image (8-bit, 1 or 3 channels, at full size: the
  // extractor applies image_scale itself).
  virtual StatusOr<FeatureSet> Extract(const cv::Mat& image) const = 0;
  virtual const ExtractorOptions& options() const = 0;
};

// Reads an image file; a missing, unreadable or non-image file is an error naming it.
StatusOr<cv::Mat> ReadImageFile(const std::string& path);
// Decodes JPEG/PNG bytes; corrupt bytes are an error, never an exception.
StatusOr<cv::Mat> DecodeImage(const std::string& bytes, int max_image_side);

}  // namespace sceneloc
