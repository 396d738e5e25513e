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
// descriptors from their own pyramid"). The one-keypoint describer and the gradient below
// also describe the detector's keypoints on its own full pyramid (sift_detector.h).
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

// The gradient of a pyramid image at every pixel: magnitude, and orientation in degrees in
// [0, 360) (y pointing up, SIFT's convention). Zero on the outermost rows and columns,
// where SIFT reads none.
struct SiftGradient {
  cv::Mat magnitude;    // CV_32F
  cv::Mat orientation;  // CV_32F
};

// A gradient of `size`, uninitialised: every row must then be filled by SiftGradientRows.
SiftGradient AllocateSiftGradient(cv::Size size);

// Fills rows [begin, end) of `g` with the gradient of the CV_32F `image` (of g's size):
// central differences, so a call reads rows begin - 1 to end of `image`; the image's edge
// rows and columns get zeros. Calls on disjoint row ranges may run at once.
void SiftGradientRows(const cv::Mat& image, int begin, int end, SiftGradient* g);

// The gradient of the CV_32F `image`, its rows cut into strips over OpenCV's parallel loops.
SiftGradient SiftGradientOf(const cv::Mat& image);

// How many row strips a parallel pass over `rows` rows uses: about twice as many as OpenCV
// has threads (uneven strips even out), each at least 16 rows; 1 when OpenCV runs serially.
int RowStripCount(int rows);

// dst = `src` blurred by a Gaussian of `sigma` (cv::GaussianBlur, its default border), in
// row strips over OpenCV's parallel loops. A strip is a sub-matrix, and OpenCV reads the
// rows around a sub-matrix from its parent for the kernel's support: the strips give the
// whole image's blur bit for bit.
void GaussianBlurInStrips(const cv::Mat& src, double sigma, cv::Mat* dst);

// One keypoint's descriptor into out[0..127], read off `g`, the gradient of the pyramid
// image the keypoint lies on; `to_octave` takes the keypoint's position and size from
// `gray`'s pixels to that image's (1 / 2^octave; 2 on SIFT's doubled base). `scratch` is
// reused between calls.
void DescribeSiftKeypoint(const SiftGradient& g, const cv::KeyPoint& k, float to_octave,
                          std::vector<float>* scratch, float* out);

}  // namespace sceneloc
