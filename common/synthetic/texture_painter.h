// Drawing the scene's texture (tour_generator.h): seeded random streams, so any part of
// the scene can be drawn alone and identically in any order, and the primitives that make
// the facade's layers and the pillars. Internal to the synthetic tour generator.
//
// Thread-safe: free functions; each call draws on the canvas it is given.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/core.hpp>

namespace sceneloc::synthetic_internal {

// A random stream of its own for every (seed, stream, tile, layer): any part of the scene
// is drawn from the same draws whatever was drawn before it.
cv::RNG RngFor(uint32_t seed, uint64_t stream, int64_t tile, int layer);

// A random colour: three channels, each uniform in 0 .. 255.
cv::Scalar RandomColour(cv::RNG& rng);

// Where primitives go. Primitives are generated in reference pixels (640-wide images) and
// scaled by `scale`. A primitive anchored in a region reaches at most a quarter tile
// beyond it, so a tile is complete once its own and its two neighbours' primitives are
// drawn.
struct Painter {
  cv::Mat* canvas;   // CV_8UC3
  double scale;      // canvas pixels per reference pixel
  int origin_x;      // canvas column of the anchoring region's left edge
  double width_ref;  // size of the anchoring region (a tile or a pillar), reference pixels
  double rows_ref;

  int Len(double ref) const { return std::max(1, Off(ref)); }
  int Off(double ref) const { return static_cast<int>(std::lround(ref * scale)); }
  cv::Point At(double ref_x, double ref_y) const { return {origin_x + Off(ref_x), Off(ref_y)}; }
  // How many of a kind of primitive to draw: `per_960_rows` for a region 960 reference
  // pixels high, in proportion for others, so the density is the same on every plane.
  int Count(int per_960_rows) const {
    return static_cast<int>(std::lround(per_960_rows * rows_ref / 960));
  }
  cv::Point RandomPoint(cv::RNG& rng) const {
    const double x = rng.uniform(0.0, width_ref);
    return At(x, rng.uniform(0.0, rows_ref));
  }
};

// Fills `rect` (clipped to the canvas) with a linear gradient between two colours.
void FillGradient(const cv::Rect& rect, const cv::Scalar& from, const cv::Scalar& to, bool vertical,
                  cv::Mat* canvas);

// The facade is drawn in layers (all tiles' panels first, then shapes, ...), so large
// panels never hide the details of a neighbouring tile. Draws layer `layer` (0 ..
// kFacadeLayers - 1) of the region `p` with `rng`.
constexpr int kFacadeLayers = 5;
void DrawFacadeLayer(int layer, cv::RNG& rng, const Painter& p);

// Softens drawn edges as a lens would.
void Soften(double scale, cv::Mat* image);

// Fine luminance grain, like weathered paint. It has no extent, so unlike the shapes it
// can be drawn per tile without seams.
void AddGrain(cv::RNG& rng, cv::Mat* image);

// The 0-2 pillars anchored in a tile: each a vertical strip with a gradient, shapes and
// text of its own, marked opaque in `mask`.
void DrawPillars(cv::RNG& rng, const Painter& p, cv::Mat* mask);

}  // namespace sceneloc::synthetic_internal
