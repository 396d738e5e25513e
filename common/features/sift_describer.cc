#include "common/features/sift_describer.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <map>
#include <opencv2/core/hal/hal.hpp>
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

using Gradient = SiftGradient;

cv::Mat Blur(const cv::Mat& image, double sigma) {
  cv::Mat out;
  GaussianBlurInStrips(image, sigma, &out);
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
      gradient = SiftGradientOf(key.second == 0 ? layer0 : Blur(layer0, sigma * std::sqrt(k2 - 1)));
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

// Spreads one sample of weighted magnitude m at histogram entry `at` (the cell row, cell
// column and bin below the sample's, margins included) over the 8 neighbouring (cell row,
// cell column, bin) entries, each by its trilinear share (fractions fr, fc, fo).
void AddSample(int at, float fr, float fc, float fo, float m, float* hist) {
  float* h = hist + at;
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

}  // namespace

int RowStripCount(int rows) {
  constexpr int kMinStripRows = 16;
  const int threads = cv::getNumThreads();
  return threads <= 1 ? 1 : std::max(1, std::min(2 * threads, rows / kMinStripRows));
}

namespace {

// Calls fn(begin, end) over [0, rows) in RowStripCount strips on OpenCV's parallel loops.
template <typename Fn>
void ForEachRowStrip(int rows, const Fn& fn) {
  const int strips = RowStripCount(rows);
  cv::parallel_for_(
      cv::Range(0, strips),
      [&](const cv::Range& range) {
        for (int s = range.start; s < range.end; ++s) {
          fn(rows * s / strips, rows * (s + 1) / strips);
        }
      },
      strips);
}

}  // namespace

void GaussianBlurInStrips(const cv::Mat& src, double sigma, cv::Mat* dst) {
  dst->create(src.size(), src.type());
  ForEachRowStrip(src.rows, [&](int begin, int end) {
    cv::Mat out = dst->rowRange(begin, end);
    cv::GaussianBlur(src.rowRange(begin, end), out, cv::Size(), sigma, sigma);
  });
}

SiftGradient SiftGradientOf(const cv::Mat& image) {
  SiftGradient g = AllocateSiftGradient(image.size());
  ForEachRowStrip(image.rows, [&](int begin, int end) { SiftGradientRows(image, begin, end, &g); });
  return g;
}

SiftGradient AllocateSiftGradient(cv::Size size) {
  // Not zeroed: SiftGradientRows writes every value of its rows, the edges' zeros too (a
  // memset of every gradient image cost about as much as computing the small ones).
  return {cv::Mat(size, CV_32F), cv::Mat(size, CV_32F)};
}

void SiftGradientRows(const cv::Mat& image, int begin, int end, SiftGradient* g) {
  CV_Assert(image.type() == CV_32FC1 && g->magnitude.size() == image.size());
  // Rows and columns on the image's edge are zero.
  for (const int edge : {0, image.rows - 1}) {
    if (edge >= begin && edge < end) {
      g->magnitude.row(edge).setTo(0);
      g->orientation.row(edge).setTo(0);
    }
  }
  begin = std::max(begin, 1);
  end = std::min(end, image.rows - 1);
  for (int r = begin; r < end; ++r) {
    for (const int edge : {0, image.cols - 1}) {
      g->magnitude.at<float>(r, edge) = 0;
      g->orientation.at<float>(r, edge) = 0;
    }
  }
  if (end <= begin || image.cols < 3) return;
  const int w = image.cols - 2;
  // Central differences, y pointing up (SIFT's convention), a row at a time; magnitude and
  // angle by the same OpenCV kernels SIFT's own histograms use.
  std::vector<float> dx(static_cast<size_t>(w)), dy(static_cast<size_t>(w));
  for (int r = begin; r < end; ++r) {
    const float* row = image.ptr<float>(r);
    const float* above = image.ptr<float>(r - 1);
    const float* below = image.ptr<float>(r + 1);
    for (int c = 0; c < w; ++c) {
      dx[static_cast<size_t>(c)] = row[c + 2] - row[c];
      dy[static_cast<size_t>(c)] = above[c + 1] - below[c + 1];
    }
    cv::hal::magnitude32f(dx.data(), dy.data(), g->magnitude.ptr<float>(r) + 1, w);
    cv::hal::fastAtan2(dy.data(), dx.data(), g->orientation.ptr<float>(r) + 1, w, true);
  }
}

void DescribeSiftKeypoint(const SiftGradient& g, const cv::KeyPoint& k, float to_octave,
                          std::vector<float>* scratch, float* out) {
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
  // Scratch: the weights, then per row of the window each sample's histogram entry, its
  // three fractions and its weighted magnitude.
  const auto span = static_cast<size_t>(2 * radius + 1);
  scratch->resize(6 * span);
  float* w = scratch->data() + radius;
  for (int t = -radius; t <= radius; ++t) w[t] = std::exp(static_cast<float>(t * t) * exp_scale);
  float* entry = scratch->data() + span;
  float* row_frac = entry + span;
  float* col_frac = row_frac + span;
  float* bin_frac = col_frac + span;
  float* weighted = bin_frac + span;
  const float centre = kCells / 2 - 0.5f;  // a sample at the centre of cell 1 counts in cell 1
  const float bins_per_degree = kBins / 360.f;
  float hist[kHistSize] = {};
  float other[kHistSize] = {};
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
    if (hi < lo) continue;
    const float* magnitude = g.magnitude.ptr<float>(r) + px;
    const float* orientation = g.orientation.ptr<float>(r) + px;
    const float wi = w[i];
    // Each sample's place, in a loop the compiler vectorises: floors by truncation of a
    // positive shift (rbin, cbin > -1; obin > -kBins), a sample outside the cells weighted 0.
    const int n = hi - lo + 1;
    for (int t = 0; t < n; ++t) {
      const int j = lo + t;
      const float rbin = static_cast<float>(j) * sin_t + row_r;
      const float cbin = static_cast<float>(j) * cos_t + row_c;
      const bool inside = (rbin > -1.f) & (rbin < kCells) & (cbin > -1.f) & (cbin < kCells);
      const float rb = inside ? rbin : 0.f;
      const float cb = inside ? cbin : 0.f;
      const float obin = (orientation[j] - angle) * bins_per_degree;
      // rbin just below kCells may round up to it when shifted: kept in the last cell.
      const int r0 = std::min(static_cast<int>(rb + 1.f) - 1, kCells - 1);
      const int c0 = std::min(static_cast<int>(cb + 1.f) - 1, kCells - 1);
      int o0 = static_cast<int>(obin + kBins) - kBins;
      row_frac[t] = rb - static_cast<float>(r0);
      col_frac[t] = cb - static_cast<float>(c0);
      bin_frac[t] = obin - static_cast<float>(o0);
      o0 += kBins * (static_cast<int>(o0 < 0) - static_cast<int>(o0 >= kBins));
      entry[t] = static_cast<float>(((r0 + 1) * kHistCols + c0 + 1) * kHistBins + o0);
      const float m = magnitude[j] * wi * w[j];  // loaded whatever `inside`: no branch
      weighted[t] = inside ? m : 0.f;
    }
    // Neighbouring samples mostly share their entries: alternating between two histograms
    // halves the chains of read-modify-writes to one address.
    int t = 0;
    for (; t + 1 < n; t += 2) {
      AddSample(static_cast<int>(entry[t]), row_frac[t], col_frac[t], bin_frac[t], weighted[t],
                hist);
      AddSample(static_cast<int>(entry[t + 1]), row_frac[t + 1], col_frac[t + 1], bin_frac[t + 1],
                weighted[t + 1], other);
    }
    if (t < n) {
      AddSample(static_cast<int>(entry[t]), row_frac[t], col_frac[t], bin_frac[t], weighted[t],
                hist);
    }
  }
  for (int e = 0; e < kHistSize; ++e) hist[e] += other[e];
  Finish(hist, out);
}

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
          DescribeSiftKeypoint(gradients.at({OctaveOf(k), LayerOf(k)}), k,
                               1.f / static_cast<float>(1 << OctaveOf(k)), &weight,
                               descriptors.ptr<float>(i));
        }
      },
      std::max(1, n / 8));
  return descriptors;
}

}  // namespace sceneloc
