#include "common/synthetic/tour_camera.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace sceneloc::synthetic_internal {

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

cv::Matx33d StripToImage(const Camera& camera, const PlaneTexture& texture, int64_t first) {
  const double ppm = texture.PixelsPerMetre();
  const cv::Vec3d& c = camera.centre;
  const cv::Matx33d plane_to_camera(
      1 / ppm, 0, static_cast<double>(first) * texture.tile_width() / ppm - c[0],  //
      0, 1 / ppm, -texture.rows() / (2 * ppm) - c[1],                              //
      0, 0, texture.plane().distance - c[2]);
  return camera.k * camera.r * plane_to_camera;
}

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

}  // namespace sceneloc::synthetic_internal
