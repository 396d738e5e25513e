// Synthetic tours: a deterministic, procedurally textured street that a camera walks
// along twice, so tests and demos can run the whole pipeline without real images.
//
// The scene is a long facade (random panels, shapes, lines and text, never periodic)
// with a row of textured pillars standing in front of it. A camera at the height of the
// facade's middle walks parallel to it, looking obliquely ahead at it.
//   Pass 0, the training tour: location i is the camera at i * step along the route.
//   Pass 1, the test pass: the same route walked again "at another time of day": the
//   camera is displaced sideways towards the facade, a little further along and turned
//   slightly, so the facade changes scale and perspective and the nearer pillars move
//   against it (parallax); brightness differs and there is new sensor noise.
// Location i of the test pass therefore shows what location i of the training tour
// shows, seen from elsewhere; locations i +- 3 and beyond share clearly less.
//
// Thread-safe: the functions share no state and may be called from several threads.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/util/status.h"

namespace sceneloc {

// The two passes over the route.
inline constexpr int kTrainingPass = 0;
inline constexpr int kTestPass = 1;

struct TourOptions {
  // Images per pass: locations 0 .. num_locations - 1 along the route. 1 .. 100000.
  int num_locations = 40;
  // Size of every image in pixels: 160 .. 4096 wide, at least 16 high, landscape and
  // at most 4:3 (image_height * 4 <= image_width * 3), so the facade fills every view.
  // The texture is drawn at a resolution proportional to image_width, so larger images
  // are not merely upsampled.
  int image_width = 640;
  int image_height = 360;
  // Seeds the scene and the sensor noise. The same options give byte-identical images;
  // location i does not depend on num_locations (a shorter tour is a prefix of a longer).
  uint32_t seed = 1;
  // Camera travel between consecutive locations, as a fraction of the camera's distance
  // to the facade. The default 0.3 makes consecutive frames of a pass show ~83% of the
  // same facade. (0, 2].
  double step = 0.3;
  // Test pass only: how far the camera is displaced sideways (towards the facade when
  // positive), as a fraction of the training camera's distance to the facade. Changes
  // the scale and perspective of the facade and the parallax of the pillars. [-0.3, 0.3].
  double lateral_shift = 0.12;
  // Test pass only: how much further along the route each test location is, as a
  // fraction of step. [-0.5, 0.5].
  double forward_offset = 0.2;
  // Test pass only: the camera is turned by this many degrees away from the direction of
  // travel (towards facing the facade squarely) and pitched up by half as much. [-5, 10]:
  // turning further ahead would show the facade's top edge in 4:3 images.
  double rotation_deg = 2.0;
  // Test pass only: every pixel value v becomes brightness_gain * v + brightness_offset
  // before noise (another time of day). Gain (0, 4], offset [-255, 255].
  double brightness_gain = 0.8;
  double brightness_offset = 12.0;
  // Standard deviation of the Gaussian sensor noise added to every pixel of both passes,
  // in grey levels (0 = none). [0, 50].
  double noise_stddev = 2.0;
  // JPEG quality of the encoded images. 1 .. 100.
  int jpeg_quality = 90;
  // Look-alike places: 0 = a street that never repeats. N > 0: the facade and the pillars
  // repeat every N blocks of 40 m (kBlockMetres; 40 / (10 * step) locations a block, 13.3 at
  // the default step), like a corridor of identical doors; each facade tile keeps one
  // small sign of its own, so repeats differ only there. [0, 1000].
  int repeat_blocks = 0;

  // OK when every field is in its documented range.
  Status Validate() const;
};

// Renders every location of pass kTrainingPass or kTestPass and returns one JPEG file's
// bytes per location, in route order. Errors: invalid options or pass
// (kInvalidArgument); OpenCV failing (kInternal). Holds every JPEG in memory (~70 KB
// each at 640x360); use WriteTour for long tours.
StatusOr<std::vector<std::string>> RenderTourJpegs(const TourOptions& options, int pass);

// File name of location `index` in a written tour: "Image000.jpg", "Image001.jpg", ...
// (the Gardens Point layout; indices above 999 get more digits).
std::string TourImageName(int index);

// Renders pass `pass` and writes dir/TourImageName(i) for every location, creating dir
// (and its parents) if needed and overwriting existing images. Errors as for
// RenderTourJpegs, plus kIoError naming the path when dir cannot be created or a file
// cannot be written. Each of `threads` threads renders and writes one image at a time, so
// memory stays bounded whatever num_locations is; the images are the same whatever the
// thread count. A failure can leave the images written before it.
Status WriteTour(const TourOptions& options, const std::string& dir, int pass, int threads = 1);

}  // namespace sceneloc
