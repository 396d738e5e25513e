// The scene's geometry and its two textured planes (tour_generator.h): the facade and,
// in front of it, a row of pillars, each drawn tile by tile on demand. Internal to the
// synthetic tour generator.
//
// Thread-safe: the constants are; a PlaneTexture is not (each render owns its own).
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <opencv2/core.hpp>

namespace sceneloc::synthetic_internal {

// Scene geometry, in metres. Only ratios matter: the facade distance sets the unit.
// World axes: X along the route, Y down, Z from the route towards the facade.
inline constexpr double kFacadeDistance = 10.0;
inline constexpr double kPillarDistance = 6.0;
// Texture is drawn in tiles of kRefTileWidth pixels at 640-pixel-wide images, scaled
// with image_width so the texture keeps about one texel per pixel at every size.
inline constexpr double kRefImageWidth = 640.0;
inline constexpr int kRefTileWidth = 512;

// A textured plane parallel to the route.
struct Plane {
  double distance;     // from the training route to the plane, metres
  double tile_metres;  // route length covered by one texture tile
  double half_height;  // metres above and below the camera; enough for every view
                       // TourOptions allows (4:3 images, rotation -5, shift -0.3)
  uint64_t stream;     // separates the planes' random streams
  bool has_pillars;    // a row of opaque pillars on a transparent plane, not a facade
};
inline constexpr Plane kFacade{kFacadeDistance, 8.0, 9.5, 1, false};
inline constexpr Plane kPillars{kPillarDistance, 5.0, 6.6, 2, true};
inline constexpr uint64_t kSensorNoiseStream = 3;
// A block of street for TourOptions::repeat_blocks: 40 m, 5 facade tiles, 8 pillar tiles.
inline constexpr double kBlockMetres = 40.0;

struct Tile {
  cv::Mat colour;  // CV_8UC3
  cv::Mat mask;    // CV_8UC1 coverage (255 = opaque); empty for the facade
};

// Generates tiles of one plane on demand and keeps the few a pass is currently using.
// Not thread-safe; each render owns its own.
class PlaneTexture {
 public:
  // period: the plane repeats every `period` tiles, each tile keeping a small sign of its
  // own (0 = never periodic).
  PlaneTexture(const Plane& plane, uint32_t seed, double scale, int64_t period = 0)
      : plane_(plane),
        seed_(seed),
        scale_(scale),
        period_(period),
        tile_width_(static_cast<int>(std::lround(kRefTileWidth * scale))),
        rows_(static_cast<int>(std::lround(2 * plane.half_height * PixelsPerMetre()))) {}

  double PixelsPerMetre() const { return kRefTileWidth * scale_ / plane_.tile_metres; }
  int tile_width() const { return tile_width_; }
  int rows() const { return rows_; }
  const Plane& plane() const { return plane_; }

  // Tiles [first, last] side by side; tiles before `first` are forgotten, since a pass
  // only moves forward.
  Tile Strip(int64_t first, int64_t last);

 private:
  // Tile k, drawn on first use.
  const Tile& Get(int64_t k);
  Tile Draw(int64_t k) const;
  Tile DrawFacadeTile(int64_t k) const;
  Tile DrawPillarTile(int64_t k) const;
  // The tile whose pattern tile k repeats: k itself on a plane that is never periodic.
  int64_t Pattern(int64_t k) const { return period_ > 0 ? ((k % period_) + period_) % period_ : k; }
  // Tile k's own sign on a periodic facade: a small plate at a height and place of its own.
  void DrawSign(int64_t k, cv::Mat* colour) const;

  const Plane plane_;
  const uint32_t seed_;
  const double scale_;
  const int64_t period_;
  const int tile_width_;
  const int rows_;
  std::map<int64_t, Tile> cache_;
};

}  // namespace sceneloc::synthetic_internal
