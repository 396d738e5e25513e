#include "common/features/holistic.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

namespace sceneloc {
namespace {

constexpr float kTwoPi = 6.28318530717958647f;
// SIFT's clamp: no single orientation of a cell dominates after normalisation.
constexpr float kClamp = 0.2f;
// Added to each neighbourhood's energy, relative to the frame's mean: flat regions (a black
// lens rim, a night sky) stay near zero instead of amplifying sensor noise into structure.
constexpr float kEnergyFloor = 0.01f;

// Gradient-orientation histogram of every cell, magnitude-weighted, each pixel's vote split
// linearly between its two nearest bins.
std::vector<float> CellHistograms(const cv::Mat& thumb, const HolisticGrid& g, int cell) {
  std::vector<float> h(static_cast<size_t>(g.size()), 0.0f);
  const int width = thumb.cols, height = thumb.rows;
  for (int y = 0; y < height; ++y) {
    const float* up = thumb.ptr<float>(std::max(0, y - 1));
    const float* row = thumb.ptr<float>(y);
    const float* down = thumb.ptr<float>(std::min(height - 1, y + 1));
    float* cells = h.data() + static_cast<size_t>(y / cell) * g.cols * g.bins;
    for (int x = 0; x < width; ++x) {
      const float gx = row[std::min(width - 1, x + 1)] - row[std::max(0, x - 1)];
      const float gy = down[x] - up[x];
      const float magnitude = std::sqrt(gx * gx + gy * gy);
      if (magnitude == 0.0f) continue;
      float angle = std::atan2(gy, gx);
      if (angle < 0) angle += kTwoPi;
      const float position = angle / kTwoPi * static_cast<float>(g.bins);
      const int b0 = static_cast<int>(position) % g.bins;
      const float frac = position - std::floor(position);
      float* bins = cells + static_cast<size_t>(x / cell) * g.bins;
      bins[b0] += magnitude * (1.0f - frac);
      bins[(b0 + 1) % g.bins] += magnitude * frac;
    }
  }
  return h;
}

// Divides every cell by the root of its 3x3 neighbourhood's energy (edges reflected), clamps
// and takes square roots (a Hellinger-style kernel: many weak gradients count like a few
// strong ones).
void NormaliseCells(const HolisticGrid& g, std::vector<float>* h) {
  std::vector<float> energy(static_cast<size_t>(g.rows * g.cols), 0.0f);
  double total = 0;
  for (int c = 0; c < g.rows * g.cols; ++c) {
    const float* v = h->data() + static_cast<size_t>(c) * g.bins;
    for (int b = 0; b < g.bins; ++b) energy[c] += v[b] * v[b];
    total += energy[c];
  }
  const float floor = kEnergyFloor * static_cast<float>(total / (g.rows * g.cols)) + 1e-6f;
  const auto reflect = [](int i, int n) { return i < 0 ? -i - 1 : (i >= n ? 2 * n - i - 1 : i); };
  for (int r = 0; r < g.rows; ++r) {
    for (int c = 0; c < g.cols; ++c) {
      float sum = floor;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          sum += energy[reflect(r + dr, g.rows) * g.cols + reflect(c + dc, g.cols)];
        }
      }
      const float scale = 1.0f / std::sqrt(sum);
      float* v = h->data() + static_cast<size_t>(r * g.cols + c) * g.bins;
      for (int b = 0; b < g.bins; ++b) v[b] = std::sqrt(std::min(kClamp, v[b] * scale));
    }
  }
}

}  // namespace

SettingTable HolisticSettings(HolisticOptions* o, const std::string& section) {
  return {
      Setting(section, "holistic_cols", &o->cols)
          .Range(4, kMaxHolisticCols)
          .Off(0)
          .Help("holistic descriptor grid width in cells (0 = none); rows by aspect"),
      Setting(section, "holistic_cell_pixels", &o->cell_pixels)
          .Range(2, 64)
          .Unit("pixels")
          .Help("cell side on the holistic thumbnail"),
      Setting(section, "holistic_bins", &o->bins)
          .Range(4, kMaxHolisticBins)
          .Help("gradient orientation bins over 360 degrees"),
      Setting(section, "holistic_max_shift", &o->max_shift)
          .Range(0, 63)
          .Help("lateral tolerance when comparing them, cells (< holistic_cols)"),
  };
}

Status HolisticOptions::Validate() const {
  HolisticOptions copy = *this;
  SCENELOC_RETURN_IF_ERROR(CheckSettings(HolisticSettings(&copy, "extractor")));
  if (enabled() && max_shift >= cols) {
    return InvalidArgument("holistic_max_shift must be < holistic_cols");
  }
  return Status::Ok();
}

HolisticGrid GridForFrame(int width, int height, const HolisticOptions& options) {
  if (!options.enabled() || width <= 0 || height <= 0) return {};
  const int rows =
      static_cast<int>(std::lround(static_cast<double>(options.cols) * height / width));
  return {options.cols, std::clamp(rows, 2, 4 * options.cols), options.bins};
}

std::vector<float> ComputeHolistic(const cv::Mat& gray, const HolisticGrid& grid, int cell_pixels) {
  cv::Mat small, thumb;
  const cv::Size size(grid.cols * cell_pixels, grid.rows * cell_pixels);
  const bool shrink = size.width <= gray.cols && size.height <= gray.rows;
  cv::resize(gray, small, size, 0, 0, shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
  small.convertTo(thumb, CV_32F);
  std::vector<float> h = CellHistograms(thumb, grid, cell_pixels);
  NormaliseCells(grid, &h);
  return h;
}

namespace {

float Value(float v) { return v; }
float Value(uint8_t v) { return static_cast<float>(v) * (1.0f / 255.0f); }

template <typename B>
float Distance(const float* a, const B* b, const HolisticGrid& grid, int max_shift) {
  const int cols = grid.cols, bins = grid.bins;
  float best = std::numeric_limits<float>::max();
  for (int shift = -max_shift; shift <= max_shift; ++shift) {
    // Cells (r, c) of a against (r, c - shift) of b, where both exist.
    const int c_begin = std::max(0, shift), c_end = cols + std::min(0, shift);
    const int span = (c_end - c_begin) * bins;
    float sum = 0;
    for (int r = 0; r < grid.rows; ++r) {
      const float* pa = a + (static_cast<size_t>(r) * cols + c_begin) * bins;
      const B* pb = b + (static_cast<size_t>(r) * cols + c_begin - shift) * bins;
      for (int i = 0; i < span; ++i) {
        const float d = pa[i] - Value(pb[i]);
        sum += d * d;
      }
    }
    best = std::min(best, sum / static_cast<float>(grid.rows * (c_end - c_begin)));
  }
  return best;
}

}  // namespace

float HolisticDistance(const float* a, const float* b, const HolisticGrid& grid, int max_shift) {
  return Distance(a, b, grid, max_shift);
}

float HolisticDistance(const float* a, const uint8_t* b, const HolisticGrid& grid, int max_shift) {
  return Distance(a, b, grid, max_shift);
}

}  // namespace sceneloc
