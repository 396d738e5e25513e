#include "common/synthetic/tour_generator.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <system_error>

namespace sceneloc {

Status TourOptions::Validate() const {
  if (num_locations < 1 || num_locations > 100000) {
    return InvalidArgument("num_locations must be in [1, 100000]");
  }
  if (image_width < 160 || image_width > 4096) {
    return InvalidArgument("image_width must be in [160, 4096]");
  }
  if (image_height < 16 || image_height * 4 > image_width * 3) {
    return InvalidArgument("image_height must be >= 16 and at most 3/4 of image_width");
  }
  if (!(step > 0.0 && step <= 2.0)) return InvalidArgument("step must be in (0, 2]");
  if (!(std::abs(lateral_shift) <= 0.3)) {
    return InvalidArgument("lateral_shift must be in [-0.3, 0.3]");
  }
  if (!(std::abs(forward_offset) <= 0.5)) {
    return InvalidArgument("forward_offset must be in [-0.5, 0.5]");
  }
  if (!(rotation_deg >= -5.0 && rotation_deg <= 10.0)) {
    return InvalidArgument("rotation_deg must be in [-5, 10]");
  }
  if (!(brightness_gain > 0.0 && brightness_gain <= 4.0)) {
    return InvalidArgument("brightness_gain must be in (0, 4]");
  }
  if (!(std::abs(brightness_offset) <= 255.0)) {
    return InvalidArgument("brightness_offset must be in [-255, 255]");
  }
  if (!(noise_stddev >= 0.0 && noise_stddev <= 50.0)) {
    return InvalidArgument("noise_stddev must be in [0, 50]");
  }
  if (jpeg_quality < 1 || jpeg_quality > 100) {
    return InvalidArgument("jpeg_quality must be in [1, 100]");
  }
  return Status::Ok();
}

std::string TourImageName(int index) {
  char name[32];
  std::snprintf(name, sizeof(name), "Image%03d.jpg", index);
  return name;
}

namespace {

// ---------------------------------------------------------------------------------------
// Scene geometry, in metres. Only ratios matter: the facade distance sets the unit.
// World axes: X along the route, Y down, Z from the route towards the facade.
constexpr double kFacadeDistance = 10.0;
constexpr double kPillarDistance = 6.0;
// Focal length over image width: a 64 degree horizontal field of view.
constexpr double kFocalPerWidth = 0.8;
// The camera looks this far ahead of perpendicular to the facade, so the view is oblique
// and a sideways displacement changes perspective, not only scale.
constexpr double kYawDeg = 15.0;
// Texture is drawn in tiles of kRefTileWidth pixels at 640-pixel-wide images, scaled
// with image_width so the texture keeps about one texel per pixel at every size.
constexpr double kRefImageWidth = 640.0;
constexpr int kRefTileWidth = 512;

// A textured plane parallel to the route.
struct Plane {
  double distance;     // from the training route to the plane, metres
  double tile_metres;  // route length covered by one texture tile
  double half_height;  // metres above and below the camera; enough for every view
                       // TourOptions allows (4:3 images, rotation -5, shift -0.3)
  uint64_t stream;     // separates the planes' random streams
  bool has_pillars;    // a row of opaque pillars on a transparent plane, not a facade
};
constexpr Plane kFacade{kFacadeDistance, 8.0, 9.5, 1, false};
constexpr Plane kPillars{kPillarDistance, 5.0, 6.6, 2, true};
constexpr uint64_t kSensorNoiseStream = 3;

// ---------------------------------------------------------------------------------------
// Seeding: every tile and layer has its own random stream derived from the seed, so any
// part of the scene can be drawn alone and identically, in any order.

uint64_t Mix(uint64_t x) {  // splitmix64's finaliser
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

cv::RNG RngFor(uint32_t seed, uint64_t stream, int64_t tile, int layer) {
  uint64_t state = Mix(Mix(Mix(seed) ^ stream) ^ static_cast<uint64_t>(tile));
  return cv::RNG(Mix(state ^ static_cast<uint64_t>(layer)));
}

// Draws from `rng` are sequenced with braces or separate statements throughout: the
// order of evaluation of function arguments is unspecified, and would let the scene
// differ between compilers.
cv::Scalar RandomColour(cv::RNG& rng) {
  return cv::Scalar{static_cast<double>(rng.uniform(0, 256)),
                    static_cast<double>(rng.uniform(0, 256)),
                    static_cast<double>(rng.uniform(0, 256))};
}

// ---------------------------------------------------------------------------------------
// Drawing. Primitives are generated in reference pixels (640-wide images) and scaled by
// `scale`. A primitive anchored in a tile reaches at most a quarter tile beyond it, so a
// tile is complete once its own and its two neighbours' primitives are drawn.

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
                  cv::Mat* canvas) {
  const cv::Rect clipped = rect & cv::Rect(0, 0, canvas->cols, canvas->rows);
  if (clipped.empty()) return;
  const int n = vertical ? rect.height : rect.width;
  cv::Mat ramp(1, n, CV_8UC3);
  for (int i = 0; i < n; ++i) {
    const double t = n > 1 ? static_cast<double>(i) / (n - 1) : 0.0;
    const cv::Scalar c = from * (1.0 - t) + to * t;
    ramp.at<cv::Vec3b>(0, i) =
        cv::Vec3b(cv::saturate_cast<uchar>(c[0]), cv::saturate_cast<uchar>(c[1]),
                  cv::saturate_cast<uchar>(c[2]));
  }
  if (vertical) ramp = ramp.reshape(3, n);
  cv::Mat full;
  cv::repeat(ramp, vertical ? 1 : rect.height, vertical ? rect.width : 1, full);
  full(clipped - rect.tl()).copyTo((*canvas)(clipped));
}

std::string RandomWord(cv::RNG& rng) {
  static constexpr char kAlphabet[] = "ABCDEFGHJKLMNPRSTUVWXYZ0123456789";
  std::string word(rng.uniform(2, 8), ' ');
  for (char& c : word) c = kAlphabet[rng.uniform(0, static_cast<int>(sizeof(kAlphabet)) - 1)];
  return word;
}

// Large panels, some with gradients: the facade's "architecture".
void DrawPanels(cv::RNG& rng, const Painter& p) {
  for (int i = 0, n = p.Count(14); i < n; ++i) {
    const double w = rng.uniform(40.0, 240.0), h = rng.uniform(60.0, 400.0);
    const cv::Point centre = p.RandomPoint(rng);
    const cv::Rect rect(centre - cv::Point(p.Off(w / 2), p.Off(h / 2)),
                        cv::Size(p.Len(w), p.Len(h)));
    const cv::Scalar a = RandomColour(rng), b = RandomColour(rng);
    if (rng.uniform(0, 2) == 0) {
      cv::rectangle(*p.canvas, rect, a, cv::FILLED);
    } else {
      FillGradient(rect, a, b, rng.uniform(0, 2) == 0, p.canvas);
    }
  }
}

void DrawPolygon(cv::RNG& rng, const cv::Point& c, const cv::Scalar& colour, const Painter& p) {
  std::vector<cv::Point> polygon(rng.uniform(3, 7));
  const double radius = rng.uniform(10.0, 50.0);
  for (size_t k = 0; k < polygon.size(); ++k) {
    const double angle = 2 * CV_PI * (k + rng.uniform(0.0, 0.8)) / polygon.size();
    polygon[k] = c + cv::Point(p.Off(radius * std::cos(angle)), p.Off(radius * std::sin(angle)));
  }
  cv::fillPoly(*p.canvas, std::vector<std::vector<cv::Point>>{polygon}, colour, cv::LINE_AA);
}

// One random filled or outlined shape, at most 50 reference pixels from its centre.
void DrawShape(cv::RNG& rng, const cv::Point& c, const Painter& p) {
  const cv::Scalar colour = RandomColour(rng);
  switch (rng.uniform(0, 5)) {
    case 0:
      cv::circle(*p.canvas, c, p.Len(rng.uniform(6.0, 40.0)), colour, cv::FILLED, cv::LINE_AA);
      break;
    case 1: {
      const cv::Size axes{p.Len(rng.uniform(8.0, 50.0)), p.Len(rng.uniform(6.0, 30.0))};
      cv::ellipse(*p.canvas, c, axes, rng.uniform(0.0, 180.0), 0, 360, colour, cv::FILLED,
                  cv::LINE_AA);
      break;
    }
    case 2:
      DrawPolygon(rng, c, colour, p);
      break;
    case 3: {
      const cv::Point half{p.Len(rng.uniform(5.0, 40.0)), p.Len(rng.uniform(5.0, 40.0))};
      cv::rectangle(*p.canvas, c - half, c + half, colour, p.Len(rng.uniform(1.0, 4.0)),
                    cv::LINE_AA);
      break;
    }
    default: {
      const int radius = p.Len(rng.uniform(8.0, 45.0));
      cv::circle(*p.canvas, c, radius, colour, p.Len(rng.uniform(2.0, 5.0)), cv::LINE_AA);
    }
  }
}

void DrawShapes(cv::RNG& rng, const Painter& p, int count) {
  for (int i = 0; i < count; ++i) DrawShape(rng, p.RandomPoint(rng), p);
}

void DrawLines(cv::RNG& rng, const Painter& p) {
  for (int i = 0, n = p.Count(20); i < n; ++i) {
    const cv::Point from = p.RandomPoint(rng);
    const double length = rng.uniform(20.0, 120.0), angle = rng.uniform(0.0, CV_PI);
    const cv::Point delta(p.Off(length * std::cos(angle)), p.Off(length * std::sin(angle)));
    const cv::Scalar colour = RandomColour(rng);
    cv::line(*p.canvas, from, from + delta, colour, p.Len(rng.uniform(1.0, 5.0)), cv::LINE_AA);
  }
}

// Text snippets: many distinctive corners and blobs, as shop signs give real scenes.
// Each is at most min(240, width_ref) reference pixels wide.
void DrawText(cv::RNG& rng, const Painter& p, int count) {
  static constexpr int kFonts[] = {cv::FONT_HERSHEY_SIMPLEX, cv::FONT_HERSHEY_DUPLEX,
                                   cv::FONT_HERSHEY_COMPLEX, cv::FONT_HERSHEY_TRIPLEX};
  const int max_width = p.Len(std::min(240.0, p.width_ref));
  for (int i = 0; i < count; ++i) {
    const std::string word = RandomWord(rng);
    const int font = kFonts[rng.uniform(0, 4)];
    const int thickness = p.Len(rng.uniform(1.0, 3.5));
    double font_scale = rng.uniform(0.5, 1.8) * p.scale;
    int baseline = 0;
    cv::Size size = cv::getTextSize(word, font, font_scale, thickness, &baseline);
    if (size.width > max_width) {
      font_scale *= static_cast<double>(max_width) / size.width;
      size = cv::getTextSize(word, font, font_scale, thickness, &baseline);
    }
    const cv::Point centre = p.RandomPoint(rng);
    cv::putText(*p.canvas, word, centre + cv::Point(-size.width / 2, size.height / 2), font,
                font_scale, RandomColour(rng), thickness, cv::LINE_AA);
  }
}

void DrawSpeckles(cv::RNG& rng, const Painter& p) {
  for (int i = 0, n = p.Count(90); i < n; ++i) {
    const cv::Point centre = p.RandomPoint(rng);
    const int radius = p.Len(rng.uniform(2.0, 5.0));
    cv::circle(*p.canvas, centre, radius, RandomColour(rng), cv::FILLED, cv::LINE_AA);
  }
}

// The facade is drawn in layers (all tiles' panels first, then shapes, ...), so large
// panels never hide the details of a neighbouring tile.
constexpr int kFacadeLayers = 5;
void DrawFacadeLayer(int layer, cv::RNG& rng, const Painter& p) {
  switch (layer) {
    case 0:
      return DrawPanels(rng, p);
    case 1:
      return DrawShapes(rng, p, p.Count(80));
    case 2:
      return DrawLines(rng, p);
    case 3:
      return DrawText(rng, p, p.Count(24));
    default:
      return DrawSpeckles(rng, p);
  }
}

// Softens drawn edges as a lens would.
void Soften(double scale, cv::Mat* image) {
  cv::GaussianBlur(*image, *image, cv::Size(), 0.8 * scale);
}

// Fine luminance grain, like weathered paint. It has no extent, so unlike the shapes it
// can be drawn per tile without seams.
void AddGrain(cv::RNG& rng, cv::Mat* image) {
  cv::Mat grain(image->size(), CV_16SC1), grain3;
  rng.fill(grain, cv::RNG::NORMAL, 0, 3);
  cv::merge(std::vector<cv::Mat>{grain, grain, grain}, grain3);
  cv::add(*image, grain3, *image, cv::noArray(), CV_8U);
}

// The 0-2 pillars anchored in a tile: each a vertical strip with a gradient, shapes and
// text of its own, marked opaque in `mask`.
void DrawPillars(cv::RNG& rng, const Painter& p, cv::Mat* mask) {
  const int count = rng.uniform(0, 3);
  for (int i = 0; i < count; ++i) {
    const double w = rng.uniform(50.0, 110.0);
    const cv::Point centre = p.RandomPoint(rng);
    const cv::Rect rect(centre.x - p.Off(w / 2), 0, p.Len(w), p.canvas->rows);
    cv::Mat pillar(rect.size(), CV_8UC3);
    const cv::Scalar top = RandomColour(rng), bottom = RandomColour(rng);
    FillGradient(cv::Rect(cv::Point(), rect.size()), top, bottom, true, &pillar);
    const Painter inner{&pillar, p.scale, 0, w, p.rows_ref};
    DrawShapes(rng, inner, p.Count(30));
    DrawText(rng, inner, p.Count(8));
    Soften(p.scale, &pillar);
    AddGrain(rng, &pillar);
    const cv::Rect visible = rect & cv::Rect(0, 0, p.canvas->cols, p.canvas->rows);
    if (visible.empty()) continue;
    pillar(visible - rect.tl()).copyTo((*p.canvas)(visible));
    (*mask)(visible).setTo(255);
  }
}

// ---------------------------------------------------------------------------------------
// Texture tiles and strips.

struct Tile {
  cv::Mat colour;  // CV_8UC3
  cv::Mat mask;    // CV_8UC1 coverage (255 = opaque); empty for the facade
};

// Generates tiles of one plane on demand and keeps the few a pass is currently using.
// Not thread-safe; each render owns its own.
class PlaneTexture {
 public:
  PlaneTexture(const Plane& plane, uint32_t seed, double scale)
      : plane_(plane),
        seed_(seed),
        scale_(scale),
        tile_width_(static_cast<int>(std::lround(kRefTileWidth * scale))),
        rows_(static_cast<int>(std::lround(2 * plane.half_height * PixelsPerMetre()))) {}

  double PixelsPerMetre() const { return kRefTileWidth * scale_ / plane_.tile_metres; }
  int tile_width() const { return tile_width_; }
  int rows() const { return rows_; }
  const Plane& plane() const { return plane_; }

  // Tiles [first, last] side by side; tiles before `first` are forgotten, since a pass
  // only moves forward.
  Tile Strip(int64_t first, int64_t last) {
    cache_.erase(cache_.begin(), cache_.lower_bound(first));
    std::vector<cv::Mat> colours, masks;
    for (int64_t k = first; k <= last; ++k) {
      const Tile& tile = Get(k);
      colours.push_back(tile.colour);
      if (!tile.mask.empty()) masks.push_back(tile.mask);
    }
    Tile strip;
    cv::hconcat(colours, strip.colour);
    if (!masks.empty()) cv::hconcat(masks, strip.mask);
    return strip;
  }

 private:
  const Tile& Get(int64_t k) {
    auto it = cache_.find(k);
    if (it == cache_.end()) it = cache_.emplace(k, Draw(k)).first;
    return it->second;
  }

  Tile Draw(int64_t k) const;
  Tile DrawFacadeTile(int64_t k) const;
  Tile DrawPillarTile(int64_t k) const;

  const Plane plane_;
  const uint32_t seed_;
  const double scale_;
  const int tile_width_;
  const int rows_;
  std::map<int64_t, Tile> cache_;
};

Tile PlaneTexture::Draw(int64_t k) const {
  return plane_.has_pillars ? DrawPillarTile(k) : DrawFacadeTile(k);
}

Tile PlaneTexture::DrawFacadeTile(int64_t k) const {
  // Draw on the tile plus a margin, so the blur sees the neighbours' pixels and tiles
  // join without seams; then crop.
  const int margin = static_cast<int>(std::ceil(8 * scale_));
  cv::RNG base_rng = RngFor(seed_, plane_.stream, 0, -1);
  cv::Mat canvas(rows_, tile_width_ + 2 * margin, CV_8UC3, RandomColour(base_rng));
  for (int layer = 0; layer < kFacadeLayers; ++layer) {
    for (int64_t j = k - 1; j <= k + 1; ++j) {  // by layer, then tile: one global order
      cv::RNG rng = RngFor(seed_, plane_.stream, j, layer);
      const int origin_x = margin + static_cast<int>(j - k) * tile_width_;
      DrawFacadeLayer(layer, rng,
                      Painter{&canvas, scale_, origin_x, kRefTileWidth, rows_ / scale_});
    }
  }
  Soften(scale_, &canvas);
  Tile tile;
  tile.colour = canvas(cv::Rect(margin, 0, tile_width_, rows_)).clone();
  cv::RNG grain_rng = RngFor(seed_, plane_.stream, k, kFacadeLayers);
  AddGrain(grain_rng, &tile.colour);
  return tile;
}

// Pillars are softened one by one, so most of a pillar tile (empty) costs nothing.
Tile PlaneTexture::DrawPillarTile(int64_t k) const {
  Tile tile;
  tile.colour = cv::Mat::zeros(rows_, tile_width_, CV_8UC3);
  tile.mask = cv::Mat::zeros(rows_, tile_width_, CV_8UC1);
  for (int64_t j = k - 1; j <= k + 1; ++j) {
    cv::RNG rng = RngFor(seed_, plane_.stream, j, 0);
    const int origin_x = static_cast<int>(j - k) * tile_width_;
    DrawPillars(rng, Painter{&tile.colour, scale_, origin_x, kRefTileWidth, rows_ / scale_},
                &tile.mask);
  }
  return tile;
}

// ---------------------------------------------------------------------------------------
// Cameras and frames.

struct Camera {
  cv::Matx33d k;     // intrinsics
  cv::Matx33d r;     // world -> camera rotation
  cv::Vec3d centre;  // world position
};

Camera CameraFor(const TourOptions& options, int pass, int index) {
  const double f = kFocalPerWidth * options.image_width;
  Camera camera;
  camera.k =
      cv::Matx33d(f, 0, options.image_width / 2.0, 0, f, options.image_height / 2.0, 0, 0, 1);
  double x = index * options.step * kFacadeDistance, z = 0;
  double yaw = kYawDeg * CV_PI / 180, pitch = 0;
  if (pass == kTestPass) {
    x += options.forward_offset * options.step * kFacadeDistance;
    z = options.lateral_shift * kFacadeDistance;
    yaw -= options.rotation_deg * CV_PI / 180;
    pitch = options.rotation_deg / 2 * CV_PI / 180;
  }
  // Camera to world: yaw about Y (towards +X, the direction of travel), then pitch up.
  const cv::Matx33d ry(std::cos(yaw), 0, std::sin(yaw), 0, 1, 0, -std::sin(yaw), 0, std::cos(yaw));
  const cv::Matx33d rx(1, 0, 0, 0, std::cos(pitch), -std::sin(pitch), 0, std::sin(pitch),
                       std::cos(pitch));
  camera.r = (ry * rx).t();
  camera.centre = cv::Vec3d(x, 0, z);
  return camera;
}

// Homography from the pixels of a strip of `texture` starting at tile `first` to the
// image: strip pixel (c, r) is the plane point ((first * tile + c) / ppm, (r - rows / 2) /
// ppm, distance).
cv::Matx33d StripToImage(const Camera& camera, const PlaneTexture& texture, int64_t first) {
  const double ppm = texture.PixelsPerMetre();
  const cv::Vec3d& c = camera.centre;
  const cv::Matx33d plane_to_camera(
      1 / ppm, 0, static_cast<double>(first) * texture.tile_width() / ppm - c[0],  //
      0, 1 / ppm, -texture.rows() / (2 * ppm) - c[1],                              //
      0, 0, texture.plane().distance - c[2]);
  return camera.k * camera.r * plane_to_camera;
}

// The tiles of `texture` that the camera sees: the image corners' rays meet the plane
// at the corners of the visible quadrilateral.
std::pair<int64_t, int64_t> VisibleTiles(const Camera& camera, const PlaneTexture& texture,
                                         const cv::Size& size) {
  const cv::Matx33d image_to_plane = StripToImage(camera, texture, 0).inv();
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (const cv::Vec3d& corner :
       {cv::Vec3d(0, 0, 1), cv::Vec3d(size.width, 0, 1), cv::Vec3d(0, size.height, 1),
        cv::Vec3d(size.width, size.height, 1)}) {
    const cv::Vec3d u = image_to_plane * corner;
    lo = std::min(lo, u[0] / u[2]);
    hi = std::max(hi, u[0] / u[2]);
  }
  const double t = texture.tile_width();
  return {static_cast<int64_t>(std::floor((lo - 2) / t)),
          static_cast<int64_t>(std::floor((hi + 2) / t))};
}

// Renders what the camera sees of one plane: colour and coverage (empty for the facade).
Tile RenderPlane(const Camera& camera, const cv::Size& size, PlaneTexture* texture) {
  const auto [first, last] = VisibleTiles(camera, *texture, size);
  const Tile strip = texture->Strip(first, last);
  const cv::Matx33d h = StripToImage(camera, *texture, first);
  Tile view;
  cv::warpPerspective(strip.colour, view.colour, h, size, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                      cv::Scalar::all(128));
  if (!strip.mask.empty()) {
    cv::warpPerspective(strip.mask, view.mask, h, size, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                        cv::Scalar(0));
  }
  return view;
}

// Renders the locations of one pass in order, sharing texture tiles between them.
// Not thread-safe.
class PassRenderer {
 public:
  PassRenderer(const TourOptions& options, int pass)
      : options_(options),
        pass_(pass),
        facade_(kFacade, options.seed, options.image_width / kRefImageWidth),
        pillars_(kPillars, options.seed, options.image_width / kRefImageWidth) {}

  // JPEG bytes of location `index`. Throws cv::Exception if OpenCV fails.
  std::string Render(int index) {
    const Camera camera = CameraFor(options_, pass_, index);
    const cv::Size size(options_.image_width, options_.image_height);
    cv::Mat image =
        Composite(RenderPlane(camera, size, &facade_), RenderPlane(camera, size, &pillars_));
    return Encode(ApplySensor(image, index));
  }

 private:
  // Pillars over facade, blended by coverage (the warped mask is anti-aliased).
  static cv::Mat Composite(const Tile& facade, const Tile& pillars) {
    cv::Mat alpha, beta, out;
    pillars.mask.convertTo(alpha, CV_32F, 1.0 / 255);
    cv::subtract(cv::Scalar(1.0), alpha, beta);
    cv::blendLinear(pillars.colour, facade.colour, alpha, beta, out);
    return out;
  }

  // Brightness change (test pass) and sensor noise (both passes).
  cv::Mat ApplySensor(const cv::Mat& image, int index) const {
    const bool test = pass_ == kTestPass;
    cv::Mat value;
    image.convertTo(value, CV_32FC3, test ? options_.brightness_gain : 1.0,
                    test ? options_.brightness_offset : 0.0);
    if (options_.noise_stddev > 0) {
      cv::Mat noise(value.size(), CV_32FC3);
      RngFor(options_.seed, kSensorNoiseStream + pass_, index, 0)
          .fill(noise, cv::RNG::NORMAL, 0, options_.noise_stddev);
      value += noise;
    }
    cv::Mat out;
    value.convertTo(out, CV_8UC3);
    return out;
  }

  std::string Encode(const cv::Mat& image) const {
    std::vector<uchar> bytes;
    cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, options_.jpeg_quality});
    return std::string(bytes.begin(), bytes.end());
  }

  const TourOptions options_;
  const int pass_;
  PlaneTexture facade_;
  PlaneTexture pillars_;
};

Status CheckArguments(const TourOptions& options, int pass) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  if (pass != kTrainingPass && pass != kTestPass) {
    return InvalidArgument("pass must be 0 (training) or 1 (test), not " + std::to_string(pass));
  }
  return Status::Ok();
}

Status WriteFile(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  file.close();
  if (!file) return IoError("cannot write '" + path.string() + "'");
  return Status::Ok();
}

}  // namespace

StatusOr<std::vector<std::string>> RenderTourJpegs(const TourOptions& options, int pass) {
  SCENELOC_RETURN_IF_ERROR(CheckArguments(options, pass));
  std::vector<std::string> jpegs;
  try {
    PassRenderer renderer(options, pass);
    for (int i = 0; i < options.num_locations; ++i) jpegs.push_back(renderer.Render(i));
  } catch (const cv::Exception& e) {
    return Internal(std::string("OpenCV failed while rendering a tour: ") + e.what());
  }
  return jpegs;
}

Status WriteTour(const TourOptions& options, const std::string& dir, int pass) {
  SCENELOC_RETURN_IF_ERROR(CheckArguments(options, pass));
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error || !std::filesystem::is_directory(dir)) {
    return IoError("cannot create directory '" + dir + "'" +
                   (error ? ": " + error.message() : std::string()));
  }
  try {
    PassRenderer renderer(options, pass);
    for (int i = 0; i < options.num_locations; ++i) {
      SCENELOC_RETURN_IF_ERROR(
          WriteFile(std::filesystem::path(dir) / TourImageName(i), renderer.Render(i)));
    }
  } catch (const cv::Exception& e) {
    return Internal(std::string("OpenCV failed while rendering a tour: ") + e.what());
  }
  return Status::Ok();
}

}  // namespace sceneloc
