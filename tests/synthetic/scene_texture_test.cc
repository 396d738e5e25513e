// The scene's textured planes (common/synthetic/scene_texture.h): tile sizes, and tiles
// that come out the same however a pass reaches them.
#include "common/synthetic/scene_texture.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

namespace sceneloc::synthetic_internal {
namespace {

// Half the reference resolution keeps the tiles small and the test quick.
constexpr double kScale = 0.5;

bool SameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// Tiles are kRefTileWidth reference pixels wide and tall enough for the plane's height,
// at the texture's scale.
TEST(SceneTextureTest, TileSizeFollowsThePlaneAndTheScale) {
  const PlaneTexture facade(kFacade, 1, kScale);
  EXPECT_EQ(facade.tile_width(), 256);
  EXPECT_DOUBLE_EQ(facade.PixelsPerMetre(), 256 / kFacade.tile_metres);
  EXPECT_EQ(facade.rows(), std::lround(2 * kFacade.half_height * facade.PixelsPerMetre()));
  EXPECT_EQ(facade.plane().distance, kFacadeDistance);
}

// A strip is its tiles side by side; the facade has no mask, the pillars' plane has one
// of the strip's size that marks only some of it opaque.
TEST(SceneTextureTest, StripsHoldTheirTilesAndMasks) {
  PlaneTexture facade(kFacade, 1, kScale);
  const Tile strip = facade.Strip(0, 2);
  EXPECT_EQ(strip.colour.cols, 3 * facade.tile_width());
  EXPECT_EQ(strip.colour.rows, facade.rows());
  EXPECT_EQ(strip.colour.type(), CV_8UC3);
  EXPECT_TRUE(strip.mask.empty());

  PlaneTexture pillars(kPillars, 1, kScale);
  const Tile pillar_strip = pillars.Strip(0, 5);
  ASSERT_EQ(pillar_strip.mask.size(), pillar_strip.colour.size());
  const int opaque = cv::countNonZero(pillar_strip.mask);
  EXPECT_GT(opaque, 0);
  EXPECT_LT(opaque, static_cast<int>(pillar_strip.mask.total()));
}

// A tile is the same drawn alone in a fresh texture or as part of a longer strip: any
// part of the scene can be drawn alone, in any order.
TEST(SceneTextureTest, TilesDoNotDependOnWhatWasDrawnBefore) {
  PlaneTexture whole(kFacade, 3, kScale);
  const Tile strip = whole.Strip(-1, 1);
  PlaneTexture alone(kFacade, 3, kScale);
  const Tile middle = alone.Strip(0, 0);
  const int w = whole.tile_width();
  EXPECT_TRUE(SameImage(strip.colour.colRange(w, 2 * w), middle.colour));
}

// Another seed draws another facade.
TEST(SceneTextureTest, SeedChangesTheTexture) {
  PlaneTexture one(kFacade, 1, kScale), two(kFacade, 2, kScale);
  cv::Mat diff;
  cv::absdiff(one.Strip(0, 0).colour, two.Strip(0, 0).colour, diff);
  EXPECT_GT(cv::mean(diff)[0], 20.0);
}

}  // namespace
}  // namespace sceneloc::synthetic_internal
