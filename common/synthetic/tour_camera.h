// The cameras of a synthetic tour (tour_generator.h) and what each sees of a textured
// plane: a homography from the plane's texture strip to the image. Internal to the
// synthetic tour generator.
//
// Thread-safe: free functions; RenderPlane uses the texture it is given.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <utility>

#include "common/synthetic/scene_texture.h"
#include "common/synthetic/tour_generator.h"

namespace sceneloc::synthetic_internal {

// Focal length over image width: a 64 degree horizontal field of view.
inline constexpr double kFocalPerWidth = 0.8;
// The camera looks this far ahead of perpendicular to the facade, so the view is oblique
// and a sideways displacement changes perspective, not only scale.
inline constexpr double kYawDeg = 15.0;

// A pinhole camera in the world of scene_texture.h.
struct Camera {
  cv::Matx33d k;     // intrinsics
  cv::Matx33d r;     // world -> camera rotation
  cv::Vec3d centre;  // world position
};

// The camera of location `index` of pass `pass` (kTrainingPass or kTestPass): the test
// pass is displaced, further along and turned as `options` say.
Camera CameraFor(const TourOptions& options, int pass, int index);

// Homography from the pixels of a strip of `texture` starting at tile `first` to the
// image: strip pixel (c, r) is the plane point ((first * tile + c) / ppm, (r - rows / 2) /
// ppm, distance).
cv::Matx33d StripToImage(const Camera& camera, const PlaneTexture& texture, int64_t first);

// The tiles of `texture` that the camera sees: the image corners' rays meet the plane
// at the corners of the visible quadrilateral.
std::pair<int64_t, int64_t> VisibleTiles(const Camera& camera, const PlaneTexture& texture,
                                         const cv::Size& size);

// Renders what the camera sees of one plane: colour and coverage (empty for the facade).
Tile RenderPlane(const Camera& camera, const cv::Size& size, PlaneTexture* texture);

}  // namespace sceneloc::synthetic_internal
