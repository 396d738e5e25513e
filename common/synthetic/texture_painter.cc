#include "common/synthetic/texture_painter.h"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace sceneloc::synthetic_internal {
namespace {

uint64_t Mix(uint64_t x) {  // splitmix64's finaliser
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
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

}  // namespace

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

}  // namespace sceneloc::synthetic_internal
