// The cameras of a synthetic tour (common/synthetic/tour_camera.h): where each pass's
// cameras stand, and plane-to-image homographies checked against a plain projection.
#include "common/synthetic/tour_camera.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sceneloc::synthetic_internal {
namespace {

// Projects the world point `x` through `camera` to pixel coordinates: K R (X - C).
cv::Point2d Project(const Camera& camera, const cv::Vec3d& x) {
  const cv::Vec3d p = camera.k * (camera.r * (x - camera.centre));
  return {p[0] / p[2], p[1] / p[2]};
}

// Training cameras stand step * facade distance apart on the route; the intrinsics put
// the principal point at the image centre with the documented focal length.
TEST(TourCameraTest, TrainingCamerasWalkTheRoute) {
  TourOptions options;
  options.step = 0.3;
  const Camera third = CameraFor(options, kTrainingPass, 3);
  EXPECT_DOUBLE_EQ(third.centre[0], 3 * 0.3 * kFacadeDistance);
  EXPECT_EQ(third.centre[2], 0.0);
  EXPECT_DOUBLE_EQ(third.k(0, 0), kFocalPerWidth * options.image_width);
  EXPECT_DOUBLE_EQ(third.k(0, 2), options.image_width / 2.0);
  EXPECT_DOUBLE_EQ(third.k(1, 2), options.image_height / 2.0);
}

// The test pass stands sideways towards the facade and further along, and looks another
// way; both rotations are proper rotations.
TEST(TourCameraTest, TestPassIsDisplacedAndTurned) {
  TourOptions options;
  const Camera train = CameraFor(options, kTrainingPass, 2);
  const Camera test = CameraFor(options, kTestPass, 2);
  EXPECT_DOUBLE_EQ(test.centre[2], options.lateral_shift * kFacadeDistance);
  EXPECT_DOUBLE_EQ(test.centre[0] - train.centre[0],
                   options.forward_offset * options.step * kFacadeDistance);
  EXPECT_GT(cv::norm(test.r - train.r), 0.01);
  for (const Camera& c : {train, test}) {
    EXPECT_LT(cv::norm(c.r * c.r.t() - cv::Matx33d::eye()), 1e-12);
    EXPECT_NEAR(cv::determinant(c.r), 1.0, 1e-12);
  }
}

// StripToImage sends a strip pixel where projecting its plane point sends it.
TEST(TourCameraTest, StripToImageAgreesWithProjection) {
  TourOptions options;
  const Camera camera = CameraFor(options, kTestPass, 5);
  const PlaneTexture texture(kFacade, 1, 1.0);
  const int64_t first = 4;
  const cv::Matx33d h = StripToImage(camera, texture, first);
  const double ppm = texture.PixelsPerMetre();
  for (const cv::Point2d strip : {cv::Point2d(0, 0), cv::Point2d(300, 500), cv::Point2d(900, 40)}) {
    const cv::Vec3d mapped = h * cv::Vec3d(strip.x, strip.y, 1);
    const cv::Vec3d world((first * texture.tile_width() + strip.x) / ppm,
                          (strip.y - texture.rows() / 2.0) / ppm, kFacade.distance);
    const cv::Point2d expected = Project(camera, world);
    EXPECT_NEAR(mapped[0] / mapped[2], expected.x, 1e-6);
    EXPECT_NEAR(mapped[1] / mapped[2], expected.y, 1e-6);
  }
}

// The visible tiles hold the plane points seen at the image's corners.
TEST(TourCameraTest, VisibleTilesCoverTheImageCorners) {
  TourOptions options;
  const Camera camera = CameraFor(options, kTrainingPass, 7);
  const PlaneTexture texture(kPillars, 1, 1.0);
  const cv::Size size(options.image_width, options.image_height);
  const auto [first, last] = VisibleTiles(camera, texture, size);
  ASSERT_LE(first, last);
  const cv::Matx33d image_to_strip = StripToImage(camera, texture, first).inv();
  for (const cv::Vec3d& corner : {cv::Vec3d(0, 0, 1), cv::Vec3d(size.width, size.height, 1)}) {
    const cv::Vec3d u = image_to_strip * corner;
    EXPECT_GE(u[0] / u[2], 0.0);
    EXPECT_LT(u[0] / u[2], static_cast<double>((last - first + 1) * texture.tile_width()));
  }
}

// The facade fills a training view (no border grey) and has no mask; the pillars' view
// has a mask of the image's size.
TEST(TourCameraTest, RenderPlaneFillsTheView) {
  TourOptions options;
  options.image_width = 320;
  options.image_height = 180;
  const Camera camera = CameraFor(options, kTrainingPass, 1);
  const cv::Size size(options.image_width, options.image_height);
  const double scale = options.image_width / kRefImageWidth;
  PlaneTexture facade(kFacade, 1, scale), pillars(kPillars, 1, scale);
  const Tile facade_view = RenderPlane(camera, size, &facade);
  EXPECT_EQ(facade_view.colour.size(), size);
  EXPECT_TRUE(facade_view.mask.empty());
  cv::Mat border;
  cv::inRange(facade_view.colour, cv::Scalar::all(128), cv::Scalar::all(128), border);
  EXPECT_LT(cv::countNonZero(border), static_cast<int>(border.total() / 1000));
  const Tile pillar_view = RenderPlane(camera, size, &pillars);
  EXPECT_EQ(pillar_view.mask.size(), size);
}

}  // namespace
}  // namespace sceneloc::synthetic_internal
