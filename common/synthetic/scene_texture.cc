#include "common/synthetic/scene_texture.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "common/synthetic/texture_painter.h"

namespace sceneloc::synthetic_internal {

Tile PlaneTexture::Strip(int64_t first, int64_t last) {
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

const Tile& PlaneTexture::Get(int64_t k) {
  auto it = cache_.find(k);
  if (it == cache_.end()) it = cache_.emplace(k, Draw(k)).first;
  return it->second;
}

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
      cv::RNG rng = RngFor(seed_, plane_.stream, Pattern(j), layer);
      const int origin_x = margin + static_cast<int>(j - k) * tile_width_;
      DrawFacadeLayer(layer, rng,
                      Painter{&canvas, scale_, origin_x, kRefTileWidth, rows_ / scale_});
    }
  }
  Soften(scale_, &canvas);
  Tile tile;
  tile.colour = canvas(cv::Rect(margin, 0, tile_width_, rows_)).clone();
  cv::RNG grain_rng = RngFor(seed_, plane_.stream, Pattern(k), kFacadeLayers);
  AddGrain(grain_rng, &tile.colour);
  if (period_ > 0) DrawSign(k, &tile.colour);
  return tile;
}

void PlaneTexture::DrawSign(int64_t k, cv::Mat* colour) const {
  // A plate about a twelfth of the tile wide with a few strokes on it, like a door number:
  // the one thing that tells repeated blocks apart. Drawn whole inside the tile (no seam).
  cv::RNG rng = RngFor(seed_, plane_.stream, k, kFacadeLayers + 1);
  const int width = std::max(4, tile_width_ / 12);
  const int height = std::max(3, width * 2 / 3);
  const int x = rng.uniform(0, std::max(1, tile_width_ - width));
  const int y = rows_ / 2 - rng.uniform(0, std::max(1, rows_ / 4));
  const cv::Rect plate(x, std::clamp(y, 0, rows_ - height), width, height);
  (*colour)(plate).setTo(RandomColour(rng));
  const int strokes = rng.uniform(2, 5);
  for (int i = 0; i < strokes; ++i) {
    const cv::Point a(plate.x + rng.uniform(0, width), plate.y + rng.uniform(0, height));
    const cv::Point b(plate.x + rng.uniform(0, width), plate.y + rng.uniform(0, height));
    cv::line(*colour, a, b, RandomColour(rng), std::max(1, static_cast<int>(2 * scale_)),
             cv::LINE_AA);
  }
}

// Pillars are softened one by one, so most of a pillar tile (empty) costs nothing.
Tile PlaneTexture::DrawPillarTile(int64_t k) const {
  Tile tile;
  tile.colour = cv::Mat::zeros(rows_, tile_width_, CV_8UC3);
  tile.mask = cv::Mat::zeros(rows_, tile_width_, CV_8UC1);
  for (int64_t j = k - 1; j <= k + 1; ++j) {
    cv::RNG rng = RngFor(seed_, plane_.stream, Pattern(j), 0);
    const int origin_x = static_cast<int>(j - k) * tile_width_;
    DrawPillars(rng, Painter{&tile.colour, scale_, origin_x, kRefTileWidth, rows_ / scale_},
                &tile.mask);
  }
  return tile;
}

}  // namespace sceneloc::synthetic_internal
