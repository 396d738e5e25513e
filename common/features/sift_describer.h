// SIFT descriptors of given keypoints, from a pyramid that holds only the images they are
// read from.
//
// Why not OpenCV's `SIFT::compute`: given keypoints, it builds the whole Gaussian pyramid
// from their lowest octave (every layer of every octave, each blurred from the one before)
// and, for each keypoint, computes the gradient of every pixel of its window afresh. The
// extractor's context descriptors (extractor.cc, ContextDescriptors) are read almost all
// from layer 0 of octaves 0 and up, and their windows overlap heavily; so here each needed
// image is blurred once, straight from the one below it (same scale space: a Gaussian of
// the difference of the variances), its gradient is computed once per pixel, and each
// keypoint only accumulates its histogram. Measured in docs/results.md ("Context
// descriptors from their own pyramid").
//
// The descriptor is Lowe's (IJCV 2004, section 6) as OpenCV 4 computes it, so that a map's
// stored descriptors and a query's mean the same whichever computed them: 4x4 cells of 8
// orientation bins; a cell is 3 x the keypoint's scale on its octave wide; samples weighted
// by a Gaussian of half the descriptor's width and spread over the neighbouring cells and
// bins by trilinear interpolation; the vector normalised, clipped at 0.2, normalised again
// and scaled to integers in [0, 255] (SIFT's byte range, held as floats).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace sceneloc {

// The descriptors (one CV_32F row of 128 per keypoint, in order) of `keypoints` in the 8-bit
// grey `gray`. Keypoints follow OpenCV's SIFT convention: `octave` packs the pyramid octave
// (low byte, signed) and the layer within it (next byte); `size` is the diameter in `gray`'s
// pixels; `angle` in degrees. The pyramid is OpenCV's: `octave_layers` scale levels per
// octave, base blur `sigma`, the input assumed blurred by 0.5.
// REQUIRES: every keypoint's octave in [0, 24) (the extractor's context keypoints; the
// octave below the input, SIFT's doubled base, is not built here) and its layer in
// [0, octave_layers + 2].
// Loops over keypoints with cv::parallel_for_ (the pool's idle threads when routed there:
// opencv_threads.h). Thread-safe; throws cv::Exception if OpenCV fails.
cv::Mat DescribeSiftKeypoints(const cv::Mat& gray, const std::vector<cv::KeyPoint>& keypoints,
                              int octave_layers, double sigma);

}  // namespace sceneloc
