// The features of one image: what the extractor produces, training consumes, the map's
// landmarks are fused from, and a thin client sends over the wire. Its own target
// (sceneloc_feature_set) needs Eigen only, so a robot's client links no OpenCV.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "common/util/status.h"

namespace sceneloc {

// SIFT descriptors have 16 histograms (4 x 4 window) of 8 orientation bins.
inline constexpr int kDescriptorSize = 128;
inline constexpr int kNumHistograms = 16;
inline constexpr int kHistogramBins = 8;

// Image sizes, pixels per side, one name per meaning:
//  - kMinImageSide: smaller images hold no usable feature and are refused everywhere;
//  - kDefaultMaxImageSide: the largest image the engine takes by default, the extractor's
//    max_image_side (a training setting, stored in the map) and a feature set's
//    (FeatureSetLimits in proto/wire.h);
//  - kMaxImageSideSetting: the most any of those settings may be set to;
//  - a server caps its requests further: limits.max_image_side (server/server_options.h,
//    4096 by default), for JPEGs and feature sets alike.
inline constexpr int kMinImageSide = 16;
inline constexpr int kDefaultMaxImageSide = 8192;
inline constexpr int kMaxImageSideSetting = 65536;

// One row per feature, kDescriptorSize columns, row-major so a row is contiguous.
using DescriptorMatrix = Eigen::Matrix<float, Eigen::Dynamic, kDescriptorSize, Eigen::RowMajor>;

struct Keypoint {
  float x = 0;         // pixels, in the working frame (extractor.h)
  float y = 0;         // pixels
  float size = 0;      // SIFT keypoint diameter, pixels
  float angle = 0;     // degrees in [0, 360), OpenCV's convention
  float response = 0;  // detector response; larger is stronger
  int octave = 0;      // OpenCV's packed octave/layer, kept so descriptors can be recomputed
};

// The grid of a holistic descriptor (holistic.h): rows x cols cells of `bins` values each.
// The largest holistic grid: the settings' ranges (holistic.h) and what a feature set from
// the network may claim (proto/wire.h). Rows follow the frame's aspect from the columns.
inline constexpr int kMaxHolisticCols = 64;
inline constexpr int kMaxHolisticRows = 256;
inline constexpr int kMaxHolisticBins = 36;

struct HolisticGrid {
  int cols = 0;
  int rows = 0;
  int bins = 0;

  int cells() const { return cols * rows; }
  int size() const { return cells() * bins; }
  bool empty() const { return size() == 0; }
  bool operator==(const HolisticGrid& o) const {
    return cols == o.cols && rows == o.rows && bins == o.bins;
  }
  bool operator!=(const HolisticGrid& o) const { return !(*this == o); }
};

struct FeatureSet {
  int image_width = 0;   // working frame the keypoints are in, pixels
  int image_height = 0;  // working frame, pixels
  std::vector<Keypoint> keypoints;
  // Row i describes keypoints[i]. Both are L2-normalised per row.
  DescriptorMatrix local;    // standard SIFT at the keypoint's size
  DescriptorMatrix context;  // SIFT at the same point and angle, twice the size
  // The holistic descriptor of the whole frame (holistic.h), holistic_grid.size() values;
  // both empty when it was not computed (a thin client may leave it out).
  HolisticGrid holistic_grid;
  std::vector<float> holistic;

  int size() const { return static_cast<int>(keypoints.size()); }
};

// L2-normalises each row of `m` in place; an all-zero row stays zero. The one normalisation
// of descriptors (the extractor's output, uint8 rows from the wire, the self-test query).
void NormaliseRows(DescriptorMatrix* m);

// Checks a feature set from an untrusted source: consistent counts, finite values, a
// holistic descriptor that matches its grid.
Status ValidateFeatureSet(const FeatureSet& features);

}  // namespace sceneloc
