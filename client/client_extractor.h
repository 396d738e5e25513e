// Feature extraction on the robot (the thin-client path): the settings and frame a feature
// set is extracted with, so that the server matches it as it would the JPEG.
//   - From a map file (best): the map's own extractor settings, and every image brought
//     into the map's working frame and holistic grid as the server would. (The server
//     decodes a JPEG straight to grey at the DCT reduction that covers the frame; an image
//     decoded here in full gives near-identical features, not bit-identical ones.)
//   - From a training settings file (or the defaults): each image in its own tour frame
//     (long side = working_size). The server rescales keypoints of another frame width;
//     the holistic grid matches the map's when the camera has the tour's aspect ratio.
#pragma once

#include <memory>
#include <string>

#include "common/features/extractor.h"
#include "common/map/map.h"
#include "common/util/status.h"

namespace sceneloc {

struct ClientExtractorSource {
  std::string map_file;  // first choice when set
  std::string config;    // else this training settings file's extractor: section
  int working_size = 0;  // > 0: overrides extractor.working_size (not with map_file)
};

class ClientExtractor {
 public:
  // Errors: an unreadable map or settings file, invalid settings.
  static StatusOr<ClientExtractor> Create(const ClientExtractorSource& source);
  // Thread-safe.
  StatusOr<FeatureSet> Extract(const cv::Mat& image) const;
  const ExtractorOptions& options() const { return extractor_->options(); }

 private:
  std::shared_ptr<const FeatureExtractor> extractor_;
  bool has_map_frame_ = false;
  int map_width_ = 0;  // the map's working frame width, when has_map_frame_
  HolisticGrid map_grid_;
};

}  // namespace sceneloc
