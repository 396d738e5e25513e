#include "common/features/sift_describer.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <map>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#if defined(__SSE__)
#include <immintrin.h>
#endif

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

// One row of a descriptor's window, placed: for each sample its histogram entry (the cell
// row, cell column and bin below the sample's, margins included, as a float) and its
// weighted magnitude's trilinear shares of the 8 entries around it: for each of the 4
// cells (kCellOffsets), the share of the bin below and of the one above, side by side
// (sample t's at pair[q][2t], pair[q][2t + 1]) as the histogram holds them.
constexpr int kCorners = 4;
constexpr int kDown = kHistCols * kHistBins;  // one cell row further
constexpr int kCellOffsets[kCorners] = {0, kHistBins, kDown, kDown + kHistBins};
struct PlacedRow {
  float* entry;
  float* pair[kCorners];
};

// What places the samples of one window row: sample j (a column offset from the keypoint)
// lies at cell coordinates (j sin_t + row_r, j cos_t + row_c).
struct WindowRow {
  float sin_t, cos_t, row_r, row_c;
  float angle, bins_per_degree;
  float wi;                // the row's Gaussian weight factor
  const float* w;          // the column's, by j
  const float* magnitude;  // the row's gradients, by j
  const float* orientation;
};

// The shares of m at trilinear fractions (fr, fc, fo), in kShareOffsets' order.
inline void Shares(float m, float fr, float fc, float fo, const PlacedRow& out, int t) {
  const float r1 = m * fr;
  const float r0w = m - r1;
  const float rc11 = r1 * fc;
  const float rc10 = r1 - rc11;
  const float rc01 = r0w * fc;
  const float rc00 = r0w - rc01;
  const float corner[kCorners] = {rc00, rc01, rc10, rc11};
  for (int q = 0; q < kCorners; ++q) {
    out.pair[q][2 * t] = corner[q] - corner[q] * fo;
    out.pair[q][2 * t + 1] = corner[q] * fo;
  }
}

// Places sample j as the t-th of the row: floors by truncation of a positive shift (rbin,
// cbin > -1; obin > -kBins), a sample outside the cells weighted 0.
inline void PlaceSample(const WindowRow& row, int j, int t, const PlacedRow& out) {
  const float rbin = static_cast<float>(j) * row.sin_t + row.row_r;
  const float cbin = static_cast<float>(j) * row.cos_t + row.row_c;
  const bool inside = (rbin > -1.f) & (rbin < kCells) & (cbin > -1.f) & (cbin < kCells);
  const float rb = inside ? rbin : 0.f;
  const float cb = inside ? cbin : 0.f;
  const float obin = (row.orientation[j] - row.angle) * row.bins_per_degree;
  // rbin just below kCells may round up to it when shifted: kept in the last cell.
  const int r0 = std::min(static_cast<int>(rb + 1.f) - 1, kCells - 1);
  const int c0 = std::min(static_cast<int>(cb + 1.f) - 1, kCells - 1);
  int o0 = static_cast<int>(obin + kBins) - kBins;
  const float fr = rb - static_cast<float>(r0);
  const float fc = cb - static_cast<float>(c0);
  const float fo = obin - static_cast<float>(o0);
  o0 += kBins * (static_cast<int>(o0 < 0) - static_cast<int>(o0 >= kBins));
  out.entry[t] = static_cast<float>(((r0 + 1) * kHistCols + c0 + 1) * kHistBins + o0);
  const float m = row.magnitude[j] * row.wi * row.w[j];  // loaded whatever `inside`: no branch
  Shares(inside ? m : 0.f, fr, fc, fo, out, t);
}

// Places samples lo to lo + n - 1 of the row as t = 0 to n - 1. With AVX2 eight at a time,
// each lane computed as PlaceSample computes it, operation for operation (the compiler left
// PlaceSample's loop scalar: it is most of a descriptor's time).
void PlaceRow(const WindowRow& row, int lo, int n, const PlacedRow& out) {
  int t = 0;
#if defined(__AVX2__)
  const __m256 sin_t = _mm256_set1_ps(row.sin_t), cos_t = _mm256_set1_ps(row.cos_t);
  const __m256 row_r = _mm256_set1_ps(row.row_r), row_c = _mm256_set1_ps(row.row_c);
  const __m256 angle = _mm256_set1_ps(row.angle);
  const __m256 bins_per_degree = _mm256_set1_ps(row.bins_per_degree);
  const __m256 wi = _mm256_set1_ps(row.wi);
  const __m256 minus_one = _mm256_set1_ps(-1.f), one = _mm256_set1_ps(1.f);
  const __m256 cells = _mm256_set1_ps(static_cast<float>(kCells));
  const __m256 bins = _mm256_set1_ps(static_cast<float>(kBins));
  const __m256i i_one = _mm256_set1_epi32(1), i_last = _mm256_set1_epi32(kCells - 1);
  const __m256i i_bins = _mm256_set1_epi32(kBins), i_top_bin = _mm256_set1_epi32(kBins - 1);
  const __m256i lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  for (; t + 8 <= n; t += 8) {
    const int j = lo + t;
    const __m256 jf = _mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(j), lanes));
    const __m256 rbin = _mm256_add_ps(_mm256_mul_ps(jf, sin_t), row_r);
    const __m256 cbin = _mm256_add_ps(_mm256_mul_ps(jf, cos_t), row_c);
    const __m256 inside = _mm256_and_ps(_mm256_and_ps(_mm256_cmp_ps(rbin, minus_one, _CMP_GT_OQ),
                                                      _mm256_cmp_ps(rbin, cells, _CMP_LT_OQ)),
                                        _mm256_and_ps(_mm256_cmp_ps(cbin, minus_one, _CMP_GT_OQ),
                                                      _mm256_cmp_ps(cbin, cells, _CMP_LT_OQ)));
    const __m256 rb = _mm256_and_ps(inside, rbin);
    const __m256 cb = _mm256_and_ps(inside, cbin);
    const __m256 obin =
        _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(row.orientation + j), angle), bins_per_degree);
    const __m256i r0 = _mm256_min_epi32(
        _mm256_sub_epi32(_mm256_cvttps_epi32(_mm256_add_ps(rb, one)), i_one), i_last);
    const __m256i c0 = _mm256_min_epi32(
        _mm256_sub_epi32(_mm256_cvttps_epi32(_mm256_add_ps(cb, one)), i_one), i_last);
    __m256i o0 = _mm256_sub_epi32(_mm256_cvttps_epi32(_mm256_add_ps(obin, bins)), i_bins);
    const __m256 fr = _mm256_sub_ps(rb, _mm256_cvtepi32_ps(r0));
    const __m256 fc = _mm256_sub_ps(cb, _mm256_cvtepi32_ps(c0));
    const __m256 fo = _mm256_sub_ps(obin, _mm256_cvtepi32_ps(o0));
    o0 = _mm256_add_epi32(o0,
                          _mm256_and_si256(_mm256_cmpgt_epi32(_mm256_setzero_si256(), o0), i_bins));
    o0 = _mm256_sub_epi32(o0, _mm256_and_si256(_mm256_cmpgt_epi32(o0, i_top_bin), i_bins));
    const __m256i cell = _mm256_add_epi32(
        _mm256_mullo_epi32(_mm256_add_epi32(r0, i_one), _mm256_set1_epi32(kHistCols)),
        _mm256_add_epi32(c0, i_one));
    const __m256i entry =
        _mm256_add_epi32(_mm256_mullo_epi32(cell, _mm256_set1_epi32(kHistBins)), o0);
    _mm256_storeu_ps(out.entry + t, _mm256_cvtepi32_ps(entry));
    const __m256 m =
        _mm256_and_ps(inside, _mm256_mul_ps(_mm256_mul_ps(_mm256_loadu_ps(row.magnitude + j), wi),
                                            _mm256_loadu_ps(row.w + j)));
    const __m256 r1 = _mm256_mul_ps(m, fr);
    const __m256 r0w = _mm256_sub_ps(m, r1);
    const __m256 rc11 = _mm256_mul_ps(r1, fc);
    const __m256 rc10 = _mm256_sub_ps(r1, rc11);
    const __m256 rc01 = _mm256_mul_ps(r0w, fc);
    const __m256 rc00 = _mm256_sub_ps(r0w, rc01);
    const __m256 corner[kCorners] = {rc00, rc01, rc10, rc11};
    for (int q = 0; q < kCorners; ++q) {
      const __m256 upper = _mm256_mul_ps(corner[q], fo);
      const __m256 lower = _mm256_sub_ps(corner[q], upper);
      // Interleaved: samples 0-1 and 4-5 of each, 2-3 and 6-7; then in sample order.
      const __m256 low = _mm256_unpacklo_ps(lower, upper);
      const __m256 high = _mm256_unpackhi_ps(lower, upper);
      _mm256_storeu_ps(out.pair[q] + 2 * t, _mm256_permute2f128_ps(low, high, 0x20));
      _mm256_storeu_ps(out.pair[q] + 2 * t + 8, _mm256_permute2f128_ps(low, high, 0x31));
    }
  }
#endif
  for (; t < n; ++t) PlaceSample(row, lo + t, t, out);
}

// Adds the placed sample t to `hist`: a pair of neighbouring bins at a time.
inline void AddPlaced(const PlacedRow& row, int t, float* hist) {
  float* h = hist + static_cast<int>(row.entry[t]);
  for (int q = 0; q < kCorners; ++q) {
    float* bins = h + kCellOffsets[q];
    const float* shares = row.pair[q] + 2 * t;
#if defined(__SSE__)
    // __m64 may alias floats.
    const __m128 sum =
        _mm_add_ps(_mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<__m64*>(bins)),
                   _mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64*>(shares)));
    _mm_storel_pi(reinterpret_cast<__m64*>(bins), sum);
#else
    bins[0] += shares[0];
    bins[1] += shares[1];
#endif
  }
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
  // Scratch: the weights, then per row of the window each sample's placement.
  const auto span = static_cast<size_t>(2 * radius + 1);
  scratch->resize((2 + 2 * kCorners) * span);
  float* w = scratch->data() + radius;
  for (int t = -radius; t <= radius; ++t) w[t] = std::exp(static_cast<float>(t * t) * exp_scale);
  PlacedRow placed;
  placed.entry = scratch->data() + span;
  for (int q = 0; q < kCorners; ++q) placed.pair[q] = placed.entry + (2 * q + 1) * span;
  const float centre = kCells / 2 - 0.5f;  // a sample at the centre of cell 1 counts in cell 1
  WindowRow row;
  row.sin_t = sin_t;
  row.cos_t = cos_t;
  row.angle = angle;
  row.bins_per_degree = kBins / 360.f;
  row.w = w;
  float hist[kHistSize] = {};
  float other[kHistSize] = {};
  for (int i = -radius; i <= radius; ++i) {
    const int r = py + i;
    if (r <= 0 || r >= rows - 1) continue;
    // rbin = j sin_t + row_r, cbin = j cos_t + row_c: the sample's cell coordinates.
    row.row_r = static_cast<float>(i) * cos_t + centre;
    row.row_c = -static_cast<float>(i) * sin_t + centre;
    int lo = std::max(-radius, 1 - px);
    int hi = std::min(radius, cols - 2 - px);
    NarrowToCells(sin_t, row.row_r, &lo, &hi);
    NarrowToCells(cos_t, row.row_c, &lo, &hi);
    if (hi < lo) continue;
    row.magnitude = g.magnitude.ptr<float>(r) + px;
    row.orientation = g.orientation.ptr<float>(r) + px;
    row.wi = w[i];
    const int n = hi - lo + 1;
    PlaceRow(row, lo, n, placed);
    // Neighbouring samples mostly share their entries: alternating between two histograms
    // halves the chains of read-modify-writes to one address.
    int t = 0;
    for (; t + 1 < n; t += 2) {
      AddPlaced(placed, t, hist);
      AddPlaced(placed, t + 1, other);
    }
    if (t < n) AddPlaced(placed, t, hist);
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
