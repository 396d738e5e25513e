#include "common/features/sift_detector.h"

#include <algorithm>
#include <cfloat>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <opencv2/core/hal/hal.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "common/features/sift_describer.h"

namespace sceneloc {
namespace {

constexpr float kInputBlur = 0.5f;        // the blur SIFT assumes of its input
constexpr int kBorder = 5;                // no keypoint this close to an octave image's edge
constexpr int kFitSteps = 5;              // Newton steps of the sub-pixel fit before it gives up
constexpr int kBins = 36;                 // orientation histogram
constexpr float kOrientationBlur = 1.5f;  // its Gaussian weight, in keypoint scales
constexpr float kOrientationReach = 3 * kOrientationBlur;
constexpr float kPeakRatio = 0.8f;        // a second peak this close to the highest: a keypoint too
constexpr float kPixelScale = 1.f / 255;  // DoG values are in grey levels; the tests in [0, 1]

// The Gaussian images (layers + 3 per octave), their differences (layers + 2) and, for the
// layers keypoints lie on (1 to layers), the gradients; octave 0 is the doubled base.
struct ScaleSpace {
  int octaves = 0;
  int layers = 0;
  std::vector<cv::Mat> gaussian;
  std::vector<cv::Mat> dog;
  std::vector<SiftGradient> gradient;

  cv::Mat& Gaussian(int o, int i) { return gaussian[static_cast<size_t>(o * (layers + 3) + i)]; }
  const cv::Mat& Dog(int o, int i) const { return dog[static_cast<size_t>(o * (layers + 2) + i)]; }
  const SiftGradient& Gradient(int o, int i) const {
    return gradient[static_cast<size_t>(o * (layers + 3) + i)];
  }
};

// A task of a parallel stage: rows [begin, end) of item `item`.
struct Strip {
  int item;
  int begin;
  int end;
};

// Rows [begin, end) of `item` cut into RowStripCount strips.
void AddStrips(int item, int begin, int end, std::vector<Strip>* strips) {
  if (end <= begin) return;
  const int count = RowStripCount(end - begin);
  for (int s = 0; s < count; ++s) {
    strips->push_back(
        {item, begin + (end - begin) * s / count, begin + (end - begin) * (s + 1) / count});
  }
}

template <typename Fn>
void ForEachStrip(const std::vector<Strip>& strips, const Fn& fn) {
  const int n = static_cast<int>(strips.size());
  cv::parallel_for_(
      cv::Range(0, n),
      [&](const cv::Range& range) {
        for (int i = range.start; i < range.end; ++i) fn(strips[static_cast<size_t>(i)]);
      },
      n);
}

// The Gaussian pyramid, blurred as Lowe's chain: each layer from the one before by the
// Gaussian that raises the blur by a factor of 2^(1/layers).
void BuildGaussians(const cv::Mat& gray, const SiftParameters& p, ScaleSpace* s) {
  cv::Mat grey_f;
  gray.convertTo(grey_f, CV_32F);
  cv::Mat doubled;
  cv::resize(grey_f, doubled, cv::Size(gray.cols * 2, gray.rows * 2), 0, 0, cv::INTER_LINEAR);
  const auto sigma = static_cast<float>(p.sigma);
  // Doubling doubles the input's assumed blur.
  const float base_blur = std::sqrt(std::max(sigma * sigma - 4 * kInputBlur * kInputBlur, 0.01f));
  s->layers = p.octave_layers;
  s->octaves =
      cvRound(std::log2(static_cast<double>(std::min(doubled.cols, doubled.rows))) - 2) + 1;
  s->gaussian.resize(static_cast<size_t>(s->octaves * (s->layers + 3)));
  std::vector<double> step(static_cast<size_t>(s->layers + 3));
  const double k = std::pow(2., 1. / s->layers);
  for (int i = 1; i < s->layers + 3; ++i) {
    const double before = std::pow(k, i - 1) * p.sigma;
    const double after = before * k;
    step[static_cast<size_t>(i)] = std::sqrt(after * after - before * before);
  }
  for (int o = 0; o < s->octaves; ++o) {
    for (int i = 0; i < s->layers + 3; ++i) {
      cv::Mat& image = s->Gaussian(o, i);
      if (o == 0 && i == 0) {
        GaussianBlurInStrips(doubled, base_blur, &image);
      } else if (i == 0) {
        // Twice the octave's base blur, at half the resolution: every second pixel.
        const cv::Mat& from = s->Gaussian(o - 1, s->layers);
        cv::resize(from, image, cv::Size(from.cols / 2, from.rows / 2), 0, 0, cv::INTER_NEAREST);
      } else {
        GaussianBlurInStrips(s->Gaussian(o, i - 1), step[static_cast<size_t>(i)], &image);
      }
    }
  }
}

// The differences of neighbouring Gaussians, and the gradients of layers 1 to layers (where
// keypoints lie: their orientation and descriptor are read there), in one parallel pass.
void BuildDogAndGradients(ScaleSpace* s) {
  const int per_octave_dog = s->layers + 2;
  s->dog.resize(static_cast<size_t>(s->octaves * per_octave_dog));
  s->gradient.resize(s->gaussian.size());
  std::vector<Strip> strips;
  for (int o = 0; o < s->octaves; ++o) {
    const cv::Size size = s->Gaussian(o, 0).size();
    for (int i = 0; i < per_octave_dog; ++i) {
      const int item = o * per_octave_dog + i;
      s->dog[static_cast<size_t>(item)].create(size, CV_32F);
      AddStrips(item, 0, size.height, &strips);
    }
    for (int i = 1; i <= s->layers; ++i) {
      const int item = o * (s->layers + 3) + i;
      s->gradient[static_cast<size_t>(item)] = AllocateSiftGradient(size);
      // Gradient items follow the DoG items.
      AddStrips(static_cast<int>(s->dog.size()) + item, 0, size.height, &strips);
    }
  }
  const int dogs = static_cast<int>(s->dog.size());
  ForEachStrip(strips, [&](const Strip& strip) {
    if (strip.item < dogs) {
      const int o = strip.item / per_octave_dog;
      const int i = strip.item % per_octave_dog;
      cv::Mat out = s->dog[static_cast<size_t>(strip.item)].rowRange(strip.begin, strip.end);
      cv::subtract(s->Gaussian(o, i + 1).rowRange(strip.begin, strip.end),
                   s->Gaussian(o, i).rowRange(strip.begin, strip.end), out);
    } else {
      const auto item = static_cast<size_t>(strip.item - dogs);
      SiftGradientRows(s->gaussian[item], strip.begin, strip.end, &s->gradient[item]);
    }
  });
}

// True when v (at column c of `row`) is at least as far from zero as every one of its 26
// neighbours in the rows above and below (`step` floats apart) of this and the adjacent
// layers, on the same side of zero.
bool IsExtremum(float v, const float* prev, const float* row, const float* next, int c,
                ptrdiff_t step) {
  const float* planes[3] = {prev, row, next};
  if (v > 0) {
    for (const float* plane : planes) {
      for (const ptrdiff_t dy : {-step, ptrdiff_t{0}, step}) {
        const float* p = plane + dy + c;
        if (v < p[-1] || v < p[0] || v < p[1]) return false;
      }
    }
    return true;
  }
  for (const float* plane : planes) {
    for (const ptrdiff_t dy : {-step, ptrdiff_t{0}, step}) {
      const float* p = plane + dy + c;
      if (v > p[-1] || v > p[0] || v > p[1]) return false;
    }
  }
  return true;
}

// Marks in mask[c] the columns in [begin, end) of `row` (`step` floats from the rows above
// and below) beyond the threshold and at least as far from zero as their 8 neighbours in
// this layer and the same pixel in the layers below and above: a first cut the compiler
// vectorises (it leaves about one column in a hundred), before the full test of IsExtremum.
void MarkCandidates(const float* prev, const float* row, const float* next, ptrdiff_t step,
                    int begin, int end, float threshold, uint8_t* mask) {
  const float* up = row - step;
  const float* down = row + step;
  for (int c = begin; c < end; ++c) {
    const float v = row[c];
    const float hi =
        std::max(std::max(std::max(row[c - 1], row[c + 1]), std::max(up[c - 1], up[c])),
                 std::max(std::max(up[c + 1], down[c - 1]),
                          std::max(std::max(down[c], down[c + 1]), std::max(prev[c], next[c]))));
    const float lo =
        std::min(std::min(std::min(row[c - 1], row[c + 1]), std::min(up[c - 1], up[c])),
                 std::min(std::min(up[c + 1], down[c - 1]),
                          std::min(std::min(down[c], down[c + 1]), std::min(prev[c], next[c]))));
    mask[c] = static_cast<uint8_t>(((v > threshold) & (v >= hi)) | ((v < -threshold) & (v <= lo)));
  }
}

// Appends to `columns` the c in [begin, end) with mask[c] set, skipping 8 clear bytes at a
// time (most are). mask must be readable to end + 7.
void CollectMarked(const uint8_t* mask, int begin, int end, std::vector<int>* columns) {
  for (int c = begin; c < end; c += 8) {
    uint64_t eight;
    std::memcpy(&eight, mask + c, sizeof eight);
    if (eight == 0) continue;
    for (int k = c; k < std::min(c + 8, end); ++k) {
      if (mask[k] != 0) columns->push_back(k);
    }
  }
}

// How the OpenCV SIFT this process runs rounds: OpenCV builds SIFT's search once per
// instruction set and runs the best the CPU has. Built for AVX2 or above its compiler fuses
// some multiply-adds (the fit's contrast, the tail of each orientation histogram loop) and
// its vector loops take 16 (AVX-512) or 8 (AVX2) floats at a time; built for SSE, 4 and no
// fusion. Computed the same way here, the keypoints are OpenCV's to the bit on this CPU
// (tests/features/sift_detector_test.cc measures it); this code is built without fusing any
// multiply-add of its own (-ffp-contract=off, common/features/CMakeLists.txt).
bool OpenCvFusesMultiplyAdds() {
  static const bool fused =
      cv::checkHardwareSupport(CV_CPU_AVX2) && cv::checkHardwareSupport(CV_CPU_FMA3);
  return fused;
}

int OpenCvVectorLanes() {
  static const int lanes = !OpenCvFusesMultiplyAdds() ? 4
                           : cv::checkHardwareSupport(CV_CPU_AVX_512F) &&
                                   cv::checkHardwareSupport(CV_CPU_AVX_512BW) &&
                                   cv::checkHardwareSupport(CV_CPU_AVX_512DQ) &&
                                   cv::checkHardwareSupport(CV_CPU_AVX_512VL)
                               ? 16
                               : 8;
  return lanes;
}

// The derivatives of the DoG at (layer, r, c) of octave o, in units of the image's [0, 1].
struct Derivatives {
  cv::Vec3f gradient;  // d/dx, d/dy, d/dlayer
  float dxx, dyy, dss, dxy, dxs, dys;
};

Derivatives DerivativesAt(const ScaleSpace& s, int o, int layer, int r, int c) {
  const cv::Mat& img = s.Dog(o, layer);
  const cv::Mat& prev = s.Dog(o, layer - 1);
  const cv::Mat& next = s.Dog(o, layer + 1);
  auto at = [](const cv::Mat& m, int y, int x) { return m.at<float>(y, x); };
  constexpr float kFirst = kPixelScale * 0.5f;
  constexpr float kSecond = kPixelScale;
  constexpr float kCross = kPixelScale * 0.25f;
  Derivatives d;
  d.gradient = cv::Vec3f((at(img, r, c + 1) - at(img, r, c - 1)) * kFirst,
                         (at(img, r + 1, c) - at(img, r - 1, c)) * kFirst,
                         (at(next, r, c) - at(prev, r, c)) * kFirst);
  const float twice = at(img, r, c) * 2;
  d.dxx = (at(img, r, c + 1) + at(img, r, c - 1) - twice) * kSecond;
  d.dyy = (at(img, r + 1, c) + at(img, r - 1, c) - twice) * kSecond;
  d.dss = (at(next, r, c) + at(prev, r, c) - twice) * kSecond;
  d.dxy = (at(img, r + 1, c + 1) - at(img, r + 1, c - 1) - at(img, r - 1, c + 1) +
           at(img, r - 1, c - 1)) *
          kCross;
  d.dxs =
      (at(next, r, c + 1) - at(next, r, c - 1) - at(prev, r, c + 1) + at(prev, r, c - 1)) * kCross;
  d.dys =
      (at(next, r + 1, c) - at(next, r - 1, c) - at(prev, r + 1, c) + at(prev, r - 1, c)) * kCross;
  return d;
}

// Lowe's section 4: moves the candidate at (*layer, *r, *c) of octave o to the sample
// nearest the extremum of the quadratic through its neighbourhood, then keeps it only if the
// extremum's contrast and its curvature ratio (edges have one large and one small) pass.
// Fills `k` (position, size, packed octave and sub-layer, response) on success.
bool FitExtremum(const ScaleSpace& s, const SiftParameters& p, int o, int* layer, int* r, int* c,
                 cv::KeyPoint* k) {
  const cv::Mat& shape = s.Dog(o, 0);
  float xi = 0, xr = 0, xc = 0;
  int step = 0;
  for (; step < kFitSteps; ++step) {
    const Derivatives d = DerivativesAt(s, o, *layer, *r, *c);
    const cv::Matx33f hessian(d.dxx, d.dxy, d.dxs, d.dxy, d.dyy, d.dys, d.dxs, d.dys, d.dss);
    const cv::Vec3f offset = hessian.solve(d.gradient, cv::DECOMP_LU);
    xi = -offset[2];
    xr = -offset[1];
    xc = -offset[0];
    if (std::abs(xi) < 0.5f && std::abs(xr) < 0.5f && std::abs(xc) < 0.5f) break;
    constexpr auto kFar = static_cast<float>(INT_MAX / 3);
    if (std::abs(xi) > kFar || std::abs(xr) > kFar || std::abs(xc) > kFar) return false;
    *c += cvRound(xc);
    *r += cvRound(xr);
    *layer += cvRound(xi);
    if (*layer < 1 || *layer > s.layers || *c < kBorder || *c >= shape.cols - kBorder ||
        *r < kBorder || *r >= shape.rows - kBorder) {
      return false;
    }
  }
  if (step >= kFitSteps) return false;

  const Derivatives d = DerivativesAt(s, o, *layer, *r, *c);
  const float value = s.Dog(o, *layer).at<float>(*r, *c);
  const cv::Vec3f& g = d.gradient;
  const float contrast =
      OpenCvFusesMultiplyAdds()
          ? std::fma(value, kPixelScale, std::fma(g[2], xi, std::fma(g[1], xr, g[0] * xc)) * 0.5f)
          : value * kPixelScale + g.dot(cv::Vec3f(xc, xr, xi)) * 0.5f;
  if (std::abs(contrast) * s.layers < static_cast<float>(p.contrast_threshold)) return false;
  const float trace = d.dxx + d.dyy;
  const float det = d.dxx * d.dyy - d.dxy * d.dxy;
  const auto edge = static_cast<float>(p.edge_threshold);
  if (det <= 0 || trace * trace * edge >= (edge + 1) * (edge + 1) * det) return false;

  const float to_base = static_cast<float>(1 << o);
  k->pt.x = (static_cast<float>(*c) + xc) * to_base;
  k->pt.y = (static_cast<float>(*r) + xr) * to_base;
  k->octave = o + (*layer << 8) + (cvRound((xi + 0.5) * 255) << 16);
  k->size = static_cast<float>(p.sigma) *
            std::pow(2.f, (static_cast<float>(*layer) + xi) / static_cast<float>(s.layers)) *
            to_base * 2;
  k->response = std::abs(contrast);
  return true;
}

// Scratch of the orientation histogram, reused between keypoints.
struct HistogramScratch {
  std::vector<float> weight, magnitude, orientation;
};

// The histogram (kBins bins) of gradient orientations within `radius` of (x, y) of `g`,
// each sample its magnitude times a Gaussian of `blur`, then smoothed by [1 4 6 4 1] / 16
// round the circle. Returns the highest bin. Each sample's weight is the exponential of its
// own squared distance, as OpenCV computes it (a product of row and column factors differs
// in the last bits, and turns an orientation now and then).
float OrientationHistogram(const SiftGradient& g, int x, int y, int radius, float blur,
                           HistogramScratch* scratch, float* hist) {
  const float exp_scale = -1.f / (2.f * blur * blur);
  const int rows = g.magnitude.rows;
  const int cols = g.magnitude.cols;
  const int lo = std::max(-radius, 1 - x);
  const int hi = std::min(radius, cols - 2 - x);
  scratch->weight.clear();
  scratch->magnitude.clear();
  scratch->orientation.clear();
  for (int i = std::max(-radius, 1 - y); i <= std::min(radius, rows - 2 - y); ++i) {
    const float* magnitude = g.magnitude.ptr<float>(y + i) + x;
    const float* orientation = g.orientation.ptr<float>(y + i) + x;
    for (int j = lo; j <= hi; ++j) {
      scratch->weight.push_back(static_cast<float>(i * i + j * j) * exp_scale);
    }
    scratch->magnitude.insert(scratch->magnitude.end(), magnitude + lo, magnitude + hi + 1);
    scratch->orientation.insert(scratch->orientation.end(), orientation + lo, orientation + hi + 1);
  }
  const int n = static_cast<int>(scratch->weight.size());
  cv::hal::exp32f(scratch->weight.data(), scratch->weight.data(), n);
  float raw[kBins + 4] = {};
  float* bins = raw + 2;  // two bins of margin each side for the smoothing
  const int lanes = OpenCvVectorLanes();
  const bool fused = OpenCvFusesMultiplyAdds();
  const int vector_end = n - n % lanes;  // OpenCV's vector loop; the rest its scalar tail
  for (int k = 0; k < n; ++k) {
    int bin = cvRound((kBins / 360.f) * scratch->orientation[static_cast<size_t>(k)]);
    if (bin >= kBins) bin -= kBins;
    const float w = scratch->weight[static_cast<size_t>(k)];
    const float m = scratch->magnitude[static_cast<size_t>(k)];
    bins[bin] = fused && k >= vector_end ? std::fma(w, m, bins[bin]) : bins[bin] + w * m;
  }
  bins[-1] = bins[kBins - 1];
  bins[-2] = bins[kBins - 2];
  bins[kBins] = bins[0];
  bins[kBins + 1] = bins[1];
  float highest = 0;
  const int smooth_end = kBins - kBins % lanes;
  for (int b = 0; b < kBins; ++b) {
    const float outer = bins[b - 2] + bins[b + 2];
    const float inner = bins[b - 1] + bins[b + 1];
    const float centre = bins[b] * (6.f / 16);
    if (!fused) {
      hist[b] = outer * (1.f / 16) + inner * (4.f / 16) + centre;
    } else if (b < smooth_end) {
      hist[b] = std::fma(outer, 1.f / 16, std::fma(inner, 4.f / 16, centre));
    } else {
      // The scalar tail, as the compiler fuses `outer / 16 + inner 4 / 16 + centre 6 / 16`.
      hist[b] = std::fma(bins[b], 6.f / 16, std::fma(outer, 1.f / 16, inner * (4.f / 16)));
    }
    highest = b == 0 ? hist[0] : std::max(highest, hist[b]);
  }
  return highest;
}

// Appends the keypoint `k` (fitted at sample (r, c) of `layer`, octave o) once per dominant
// orientation: every local peak of the histogram within kPeakRatio of the highest, its angle
// interpolated by a parabola through the peak and its neighbours.
void AddOriented(const ScaleSpace& s, int o, int layer, int r, int c, const cv::KeyPoint& k,
                 HistogramScratch* scratch, std::vector<cv::KeyPoint>* out) {
  const float scale = k.size * 0.5f / static_cast<float>(1 << o);
  float hist[kBins];
  const float highest =
      OrientationHistogram(s.Gradient(o, layer), c, r, cvRound(kOrientationReach * scale),
                           kOrientationBlur * scale, scratch, hist);
  const float threshold = highest * kPeakRatio;
  for (int j = 0; j < kBins; ++j) {
    const int left = j > 0 ? j - 1 : kBins - 1;
    const int right = j < kBins - 1 ? j + 1 : 0;
    if (!(hist[j] > hist[left] && hist[j] > hist[right] && hist[j] >= threshold)) continue;
    const float curvature = OpenCvFusesMultiplyAdds()
                                ? std::fma(-2.f, hist[j], hist[left]) + hist[right]
                                : hist[left] - 2 * hist[j] + hist[right];
    float bin = static_cast<float>(j) + 0.5f * (hist[left] - hist[right]) / curvature;
    if (bin < 0) bin += kBins;
    if (bin >= kBins) bin -= kBins;
    cv::KeyPoint oriented = k;
    oriented.angle = OpenCvFusesMultiplyAdds() ? std::fma(-(360.f / kBins), bin, 360.f)
                                               : 360.f - (360.f / kBins) * bin;
    if (std::abs(oriented.angle - 360.f) < FLT_EPSILON) oriented.angle = 0.f;
    out->push_back(oriented);
  }
}

// The keypoints of the scale space (positions on the doubled base, octaves from 0 there),
// in an order that depends only on the image.
std::vector<cv::KeyPoint> FindKeypoints(const ScaleSpace& s, const SiftParameters& p) {
  // Half the contrast threshold, per layer, in grey levels: a cheap first cut.
  const int threshold = cvFloor(0.5 * p.contrast_threshold / s.layers * 255);
  std::vector<Strip> strips;
  for (int o = 0; o < s.octaves; ++o) {
    const int rows = s.Dog(o, 0).rows;
    for (int i = 1; i <= s.layers; ++i)
      AddStrips(o * (s.layers + 2) + i, kBorder, rows - kBorder, &strips);
  }
  std::vector<std::vector<cv::KeyPoint>> found(strips.size());
  const int n = static_cast<int>(strips.size());
  cv::parallel_for_(
      cv::Range(0, n),
      [&](const cv::Range& range) {
        HistogramScratch scratch;
        std::vector<uint8_t> mask;
        std::vector<int> columns;
        for (int t = range.start; t < range.end; ++t) {
          const Strip& strip = strips[static_cast<size_t>(t)];
          const int o = strip.item / (s.layers + 2);
          const int i = strip.item % (s.layers + 2);
          const cv::Mat& img = s.Dog(o, i);
          const auto step = static_cast<ptrdiff_t>(img.step1());
          mask.assign(static_cast<size_t>(img.cols) + 8, 0);  // 8 bytes of slack: CollectMarked
          for (int r = strip.begin; r < strip.end; ++r) {
            const float* row = img.ptr<float>(r);
            const float* prev = s.Dog(o, i - 1).ptr<float>(r);
            const float* next = s.Dog(o, i + 1).ptr<float>(r);
            MarkCandidates(prev, row, next, step, kBorder, img.cols - kBorder,
                           static_cast<float>(threshold), mask.data());
            columns.clear();
            CollectMarked(mask.data(), kBorder, img.cols - kBorder, &columns);
            for (const int c : columns) {
              if (!IsExtremum(row[c], prev, row, next, c, step)) continue;
              int layer = i, rr = r, cc = c;
              cv::KeyPoint k;
              if (!FitExtremum(s, p, o, &layer, &rr, &cc, &k)) continue;
              AddOriented(s, o, layer, rr, cc, k, &scratch, &found[static_cast<size_t>(t)]);
            }
          }
        }
      },
      n);
  std::vector<cv::KeyPoint> all;
  for (const auto& f : found) all.insert(all.end(), f.begin(), f.end());
  return all;
}

}  // namespace

void DetectAndDescribeSift(const cv::Mat& gray, const SiftParameters& parameters,
                           std::vector<cv::KeyPoint>* keypoints, cv::Mat* descriptors) {
  CV_Assert(gray.type() == CV_8UC1 && parameters.octave_layers > 0);
  ScaleSpace s;
  BuildGaussians(gray, parameters, &s);
  BuildDogAndGradients(&s);
  std::vector<cv::KeyPoint> found = FindKeypoints(s, parameters);
  cv::KeyPointsFilter::removeDuplicatedSorted(found);
  if (parameters.max_features > 0) cv::KeyPointsFilter::retainBest(found, parameters.max_features);
  // From the doubled base's pixels and octaves to the input's: octave 0 there is -1 here.
  for (cv::KeyPoint& k : found) {
    k.octave = (k.octave & ~0xff) | ((k.octave - 1) & 0xff);
    k.pt *= 0.5f;
    k.size *= 0.5f;
  }
  const int n = static_cast<int>(found.size());
  cv::Mat out(n, 128, CV_32F);
  cv::parallel_for_(
      cv::Range(0, n),
      [&](const cv::Range& range) {
        std::vector<float> scratch;
        for (int i = range.start; i < range.end; ++i) {
          const cv::KeyPoint& k = found[static_cast<size_t>(i)];
          const int octave = static_cast<int8_t>(k.octave & 0xff);
          const int layer = (k.octave >> 8) & 0xff;
          const float to_octave = octave >= 0 ? 1.f / static_cast<float>(1 << octave)
                                              : static_cast<float>(1 << -octave);
          DescribeSiftKeypoint(s.Gradient(octave + 1, layer), k, to_octave, &scratch,
                               out.ptr<float>(i));
        }
      },
      std::max(1, n / 8));
  *keypoints = std::move(found);
  *descriptors = out;
}

}  // namespace sceneloc
