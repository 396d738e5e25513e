// A holistic descriptor of a whole frame: a coarse grid of gradient-orientation histograms
// (HOG-like), each cell normalised by the gradient energy of its 3x3 neighbourhood.
//
// Local features find *which* tour frame a query shares points with; this finds *which*
// tour frame a query looks like as a whole. Its gradients survive what defeats SIFT's
// keypoint detector: darkness (night frames), blur, tiny or low-texture images (a 160x120
// fish-eye corridor). The comparison tolerates a lateral shift of the view (the same place
// seen from the other side of a path) by taking the best of a few horizontal cell offsets.
// It is our departure from the paper (measured in docs/results.md): a second source of
// candidate locations and of evidence for them, beside the landmarks' L(l).
//
// Thread-safe: free functions without shared state.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "common/features/feature_set.h"
#include "common/util/settings.h"
#include "common/util/status.h"

namespace sceneloc {

struct HolisticOptions {
  // Width of the grid in cells (0 = no holistic descriptor). The rows follow the frame's
  // aspect ratio, so cells are square: 16 cells on a 16:9 frame give 16 x 9.
  int cols = 16;
  // Cell side in pixels of the thumbnail the image is reduced to (cols * cell wide).
  int cell_pixels = 8;
  // Orientation bins over the full circle (signed gradients: dark-to-light differs from
  // light-to-dark, which keeps a lit wall and its shadow apart).
  int bins = 12;
  // Lateral tolerance when two descriptors are compared (HolisticDistance), in cells: 2 of
  // 16 is an eighth of the frame's width (the same place seen from the other side of a
  // path).
  int max_shift = 2;

  bool enabled() const { return cols > 0; }
  // The ranges of HolisticSettings, and max_shift < cols.
  Status Validate() const;
};

// The fields of `o` as settings: `section`.holistic_cols, ... (training files put them under
// extractor:).
SettingTable HolisticSettings(HolisticOptions* o, const std::string& section);

// The grid for a frame of `width` x `height` pixels: options.cols wide, rows by aspect
// (at least 2). Empty when holistic descriptors are disabled.
HolisticGrid GridForFrame(int width, int height, const HolisticOptions& options);

// The descriptor of an 8-bit greyscale image on `grid`, with cells of `cell_pixels`
// (the image is resized to grid.cols * cell_pixels by grid.rows * cell_pixels, whatever
// its aspect). Values are in [0, 1]; cell (r, c) holds bins r*cols*bins + c*bins + [0, bins).
// REQUIRES: !grid.empty(), gray is CV_8UC1 and non-empty.
std::vector<float> ComputeHolistic(const cv::Mat& gray, const HolisticGrid& grid, int cell_pixels);

// Dissimilarity of two descriptors on the same grid: the smallest, over horizontal cell
// offsets in [-max_shift, max_shift], of the mean squared difference per overlapping cell.
// 0 for identical frames. REQUIRES: a.size() == b.size() == grid.size(),
// 0 <= max_shift < grid.cols.
float HolisticDistance(const float* a, const float* b, const HolisticGrid& grid, int max_shift);
// The same against `b` stored as unit bytes (round(255 x), as a map holds its tour's).
float HolisticDistance(const float* a, const uint8_t* b, const HolisticGrid& grid, int max_shift);

}  // namespace sceneloc
