// SIFT keypoints and descriptors (Lowe, IJCV 2004) from one scale space built on every core.
//
// Why not `cv::SIFT::detectAndCompute`: OpenCV 4.6 builds the Gaussian pyramid on one
// thread, each image blurred from the one before, and that is about a third of plain SIFT's
// time; its other stages (difference of Gaussians, extremum search, descriptors) already
// run as parallel loops. On an idle pool of two a lone frame's SIFT therefore takes 0.72x
// its one-thread time, not 0.5x (docs/results.md, "Latency near the floor"). Here each
// pyramid image is blurred in row strips on every core: a strip's blur reads the rows
// beyond it that its kernel reaches (OpenCV filters a sub-matrix with its parent's pixels
// as the border), so the strips give the whole image's blur bit for bit. The differences
// of Gaussians, the gradients and the extremum search run in strips too, and the
// descriptors per keypoint.
//
// The keypoints are meant to be OpenCV's, so that a map trained with `cv::SIFT` and a
// query detected here read the same: the same scale space (the input doubled by linear
// interpolation and blurred from an assumed 0.5 to sigma; octave_layers + 3 images per
// octave, each blurred from the one before; the next octave starts from the layer of twice
// the octave's base blur, halved by dropping pixels), the same candidates (a difference of
// Gaussians at least as large as its 26 neighbours, beyond half the contrast threshold),
// the same fit (up to five Newton steps of the quadratic through the 3x3x3 neighbourhood,
// then the contrast and edge tests), the same orientations (a 36-bin histogram of the
// gradient within 4.5 scales, Gaussian-weighted at 1.5 scales, smoothed, every peak within
// 80% of the highest interpolated into its own keypoint), the same duplicate removal and
// the same cap. Measured against OpenCV in tests/features/sift_detector_test.cc and
// docs/results.md ("SIFT on every core").
#pragma once

#include <opencv2/core.hpp>
#include <vector>

namespace sceneloc {

// cv::SIFT::create's parameters, with its defaults.
struct SiftParameters {
  int max_features = 0;  // strongest kept (ties at the limit kept, as OpenCV does); 0 = all
  int octave_layers = 3;
  double contrast_threshold = 0.04;
  double edge_threshold = 10;
  double sigma = 1.6;
};

// The keypoints of the 8-bit grey `gray` (OpenCV's conventions: `octave` packs the signed
// octave, -1 being the doubled base, in its low byte, the layer in the next; `size` the
// diameter in `gray`'s pixels; `angle` in degrees) and their descriptors, a CV_32F row of
// 128 each, in order: what `cv::SIFT::detectAndCompute` returns.
// OpenCV's parallel loops carry the work (opencv_threads.h routes them to the engine pool).
// Thread-safe; throws cv::Exception if OpenCV fails.
void DetectAndDescribeSift(const cv::Mat& gray, const SiftParameters& parameters,
                           std::vector<cv::KeyPoint>* keypoints, cv::Mat* descriptors);

}  // namespace sceneloc
