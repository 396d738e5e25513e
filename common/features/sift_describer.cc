#include "common/features/sift_describer.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <map>
#include <opencv2/imgproc.hpp>
#include <utility>

namespace sceneloc {
namespace {

constexpr int kCells = 4;          // cells per side of the descriptor (Lowe's d)
constexpr int kBins = 8;           // orientation bins per cell (Lowe's n)
constexpr float kCellWidth = 3.f;  // a cell's width in units of the keypoint's scale
constexpr float kClip = 0.2f;      // no bin above this share of the vector's norm
constexpr float kByteScale = 512.f;
constexpr float kInputBlur = 0.5f;  // the blur SIFT assumes of its input
// The histogram carries one cell and one bin of margin on each side, so that trilinear
// interpolation writes without bounds checks; the margins are folded or dropped at the end.
constexpr int kHistCols = kCells + 2;
constexpr int kHistBins = kBins + 2;
constexpr int kHistSize = kHistCols * kHistCols * kHistBins;

int OctaveOf(const cv::KeyPoint& k) { return static_cast<int8_t>(k.octave & 0xff); }
int LayerOf(const cv::KeyPoint& k) { return (k.octave >> 8) & 0xff; }

// The gradient of a pyramid image at every pixel: magnitude, and orientation in degrees in
// [0, 360]. Zero on the outermost rows and columns, where SIFT reads none.
struct Gradient {
  cv::Mat magnitude;
  cv::Mat orientation;
};

Gradient GradientOf(const cv::Mat& image) {
  Gradient g{cv::Mat::zeros(image.size(), CV_32F), cv::Mat::zeros(image.size(), CV_32F)};
  if (image.rows < 3 || image.cols < 3) return g;
  const int w = image.cols - 2;
  const int h = image.rows - 2;
  // Central differences, y pointing up (SIFT's convention).
  const cv::Mat dx = image(cv::Rect(2, 1, w, h)) - image(cv::Rect(0, 1, w, h));
  const cv::Mat dy = image(cv::Rect(1, 0, w, h)) - image(cv::Rect(1, 2, w, h));
  cv::Mat magnitude = g.magnitude(cv::Rect(1, 1, w, h));
  cv::Mat orientation = g.orientation(cv::Rect(1, 1, w, h));
  cv::cartToPolar(dx, dy, magnitude, orientation, /*angleInDegrees=*/true);
  return g;
}

cv::Mat Blur(const cv::Mat& image, double sigma) {
  cv::Mat out;
  cv::GaussianBlur(image, out, cv::Size(), sigma, sigma);
  return out;
}

// The gradients of the pyramid images that `keypoints` are read from, keyed by (octave,
// layer). Layer 0 of octave o + 1 is layer 0 of octave o blurred to twice its scale and
// halved (where SIFT halves layer `octave_layers`, the same image); layer l > 0 is layer 0
// blurred to sigma 2^(l / octave_layers). Each image is blurred straight from layer 0 by the
// Gaussian that makes up the difference of variances; SIFT blurs layer by layer, the same
// scale space up to rounding.
std::map<std::pair<int, int>, Gradient> PyramidGradients(const cv::Mat& gray,
                                                         const std::vector<cv::KeyPoint>& keypoints,
                                                         int octave_layers, double sigma) {
  std::map<std::pair<int, int>, Gradient> gradients;
  int top = 0;
  for (const cv::KeyPoint& k : keypoints) {
    gradients[{OctaveOf(k), LayerOf(k)}];
    top = std::max(top, OctaveOf(k));
  }
  cv::Mat base;
  gray.convertTo(base, CV_32F);
  cv::Mat layer0 = Blur(base, std::sqrt(std::max(sigma * sigma - kInputBlur * kInputBlur, 0.01)));
  for (int octave = 0; octave <= top; ++octave) {
    for (auto& [key, gradient] : gradients) {
      if (key.first != octave) continue;
      const double k2 = std::pow(2.0, 2.0 * key.second / octave_layers);
      gradient = GradientOf(key.second == 0 ? layer0 : Blur(layer0, sigma * std::sqrt(k2 - 1)));
    }
    if (octave == top || layer0.cols < 2 || layer0.rows < 2) break;
    cv::resize(Blur(layer0, sigma * std::sqrt(3.0)), layer0,
               cv::Size(layer0.cols / 2, layer0.rows / 2), 0, 0, cv::INTER_NEAREST);
  }
  return gradients;
}

// Narrows [lo, hi] towards the integers j with -1 < a j + b < kCells (kept conservative: the
// caller still checks each j exactly).
void NarrowToCells(float a, float b, int* lo, int* hi) {
  if (std::abs(a) < 1e-12f) {
    if (!(b > -1.f && b < kCells)) *hi = *lo - 1;
    return;
  }
  float t1 = (-1.f - b) / a;
  float t2 = (kCells - b) / a;
  if (t1 > t2) std::swap(t1, t2);
  // Clamped in float first: a nearly flat a puts t far outside int's range.
  const float lo_f = std::floor(std::max(t1, static_cast<float>(*lo) - 1.f));
  const float hi_f = std::ceil(std::min(t2, static_cast<float>(*hi) + 1.f));
  *lo = std::max(*lo, static_cast<int>(lo_f));
  *hi = std::min(*hi, static_cast<int>(hi_f));
}

// Spreads one sample of weighted magnitude m at (rbin, cbin, obin) over the 8 neighbouring
// (cell row, cell column, bin) entries, each by its trilinear share.
void AddSample(float rbin, float cbin, float obin, float m, float* hist) {
  const int r0 = static_cast<int>(std::floor(rbin));
  const int c0 = static_cast<int>(std::floor(cbin));
  int o0 = static_cast<int>(std::floor(obin));
  const float fr = rbin - r0;
  const float fc = cbin - c0;
  const float fo = obin - o0;
  if (o0 < 0) o0 += kBins;
  if (o0 >= kBins) o0 -= kBins;
  float* h = hist + ((r0 + 1) * kHistCols + c0 + 1) * kHistBins + o0;
  const float r1 = m * fr;
  const float r0w = m - r1;
  const float rc11 = r1 * fc;
  const float rc10 = r1 - rc11;
  const float rc01 = r0w * fc;
  const float rc00 = r0w - rc01;
  const int down = kHistCols * kHistBins;
  h[0] += rc00 - rc00 * fo;
  h[1] += rc00 * fo;
  h[kHistBins] += rc01 - rc01 * fo;
  h[kHistBins + 1] += rc01 * fo;
  h[down] += rc10 - rc10 * fo;
  h[down + 1] += rc10 * fo;
  h[down + kHistBins] += rc11 - rc11 * fo;
  h[down + kHistBins + 1] += rc11 * fo;
}

// The 128 values of a filled histogram: orientation margins folded round, normalised,
// clipped at kClip of the norm, normalised again and scaled to integers in [0, 255].
void Finish(float* hist, float* out) {
  float raw[kCells * kCells * kBins];
  for (int r = 0; r < kCells; ++r) {
    for (int c = 0; c < kCells; ++c) {
      float* h = hist + ((r + 1) * kHistCols + c + 1) * kHistBins;
      h[0] += h[kBins];
      h[1] += h[kBins + 1];
      std::copy(h, h + kBins, raw + (r * kCells + c) * kBins);
    }
  }
  float norm2 = 0;
  for (const float v : raw) norm2 += v * v;
  const float clip = std::sqrt(norm2) * kClip;
  norm2 = 0;
  for (float& v : raw) {
    v = std::min(v, clip);
    norm2 += v * v;
  }
  const float scale = kByteScale / std::max(std::sqrt(norm2), FLT_EPSILON);
  for (int i = 0; i < kCells * kCells * kBins; ++i) {
    out[i] = static_cast<float>(cv::saturate_cast<uchar>(raw[i] * scale));
  }
}

// One keypoint's descriptor into out[0..127]. `weight` is scratch.
void Describe(const Gradient& g, const cv::KeyPoint& k, std::vector<float>* weight, float* out) {
  const float to_octave = 1.f / static_cast<float>(1 << OctaveOf(k));
  const int px = cvRound(k.pt.x * to_octave);
  const int py = cvRound(k.pt.y * to_octave);
  float angle = 360.f - k.angle;  // SIFT's keypoint angles run the other way
  if (std::abs(angle - 360.f) < FLT_EPSILON) angle = 0.f;
  const float cell = kCellWidth * k.size * 0.5f * to_octave;
  const int rows = g.magnitude.rows;
  const int cols = g.magnitude.cols;
  const int radius = std::min(cvRound(cell * 1.4142135623730951f * (kCells + 1) * 0.5f),
                              static_cast<int>(std::sqrt(static_cast<double>(cols) * cols +
                                                         static_cast<double>(rows) * rows)));
  const float radians = angle * static_cast<float>(CV_PI / 180);
  const float cos_t = std::cos(radians) / cell;
  const float sin_t = std::sin(radians) / cell;
  // The weight exp(-|x|^2 / (2 (kCells / 2)^2)), x in cell units, needs no rotation (a
  // rotation keeps |x|) and splits into a row and a column factor.
  const float exp_scale = -1.f / (kCells * kCells * 0.5f) / (cell * cell);
  weight->resize(static_cast<size_t>(2 * radius + 1));
  for (int t = -radius; t <= radius; ++t) {
    (*weight)[static_cast<size_t>(t + radius)] = std::exp(static_cast<float>(t * t) * exp_scale);
  }
  const float* w = weight->data() + radius;
  const float centre = kCells / 2 - 0.5f;  // a sample at the centre of cell 1 counts in cell 1
  const float bins_per_degree = kBins / 360.f;
  float hist[kHistSize] = {};
  for (int i = -radius; i <= radius; ++i) {
    const int r = py + i;
    if (r <= 0 || r >= rows - 1) continue;
    // rbin = j sin_t + row_r, cbin = j cos_t + row_c: the sample's cell coordinates.
    const float row_r = static_cast<float>(i) * cos_t + centre;
    const float row_c = -static_cast<float>(i) * sin_t + centre;
    int lo = std::max(-radius, 1 - px);
    int hi = std::min(radius, cols - 2 - px);
    NarrowToCells(sin_t, row_r, &lo, &hi);
    NarrowToCells(cos_t, row_c, &lo, &hi);
    const float* magnitude = g.magnitude.ptr<float>(r) + px;
    const float* orientation = g.orientation.ptr<float>(r) + px;
    for (int j = lo; j <= hi; ++j) {
      const float rbin = static_cast<float>(j) * sin_t + row_r;
      const float cbin = static_cast<float>(j) * cos_t + row_c;
      if (!(rbin > -1.f && rbin < kCells && cbin > -1.f && cbin < kCells)) continue;
      AddSample(rbin, cbin, (orientation[j] - angle) * bins_per_degree, magnitude[j] * w[i] * w[j],
                hist);
    }
  }
  Finish(hist, out);
}

}  // namespace

cv::Mat DescribeSiftKeypoints(const cv::Mat& gray, const std::vector<cv::KeyPoint>& keypoints,
                              int octave_layers, double sigma) {
  CV_Assert(gray.type() == CV_8UC1 && octave_layers > 0);
  cv::Mat descriptors(static_cast<int>(keypoints.size()), kCells * kCells * kBins, CV_32F);
  if (keypoints.empty()) return descriptors;
  for (const cv::KeyPoint& k : keypoints) {
    CV_Assert(OctaveOf(k) >= 0 && OctaveOf(k) < 24 && LayerOf(k) <= octave_layers + 2);
  }
  const auto gradients = PyramidGradients(gray, keypoints, octave_layers, sigma);
  const int n = static_cast<int>(keypoints.size());
  // A few keypoints per task: each takes a few microseconds.
  cv::parallel_for_(
      cv::Range(0, n),
      [&](const cv::Range& range) {
        std::vector<float> weight;
        for (int i = range.start; i < range.end; ++i) {
          const cv::KeyPoint& k = keypoints[static_cast<size_t>(i)];
          Describe(gradients.at({OctaveOf(k), LayerOf(k)}), k, &weight, descriptors.ptr<float>(i));
        }
      },
      std::max(1, n / 8));
  return descriptors;
}

}  // namespace sceneloc
