#include "common/synthetic/tour_generator.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <system_error>
#include <thread>

#include "common/image/image_codec.h"
#include "common/synthetic/scene_texture.h"
#include "common/synthetic/texture_painter.h"
#include "common/synthetic/tour_camera.h"
#include "common/util/check.h"

// The scene is drawn by texture_painter (primitives, random streams), laid on planes by
// scene_texture (facade, pillars) and seen through tour_camera (cameras, homographies);
// this file renders and writes the passes.

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
  if (repeat_blocks < 0 || repeat_blocks > 1000) {
    return InvalidArgument("repeat_blocks must be in [0, 1000]");
  }
  return Status::Ok();
}

std::string TourImageName(int index) {
  char name[32];
  std::snprintf(name, sizeof(name), "Image%03d.jpg", index);
  return name;
}

namespace {

using synthetic_internal::Camera;
using synthetic_internal::CameraFor;
using synthetic_internal::kBlockMetres;
using synthetic_internal::kFacade;
using synthetic_internal::kPillars;
using synthetic_internal::kRefImageWidth;
using synthetic_internal::kSensorNoiseStream;
using synthetic_internal::Plane;
using synthetic_internal::PlaneTexture;
using synthetic_internal::RenderPlane;
using synthetic_internal::RngFor;
using synthetic_internal::Tile;

// Renders the locations of one pass in order, sharing texture tiles between them.
// Not thread-safe.
class PassRenderer {
 public:
  PassRenderer(const TourOptions& options, int pass)
      : options_(options),
        pass_(pass),
        facade_(kFacade, options.seed, options.image_width / kRefImageWidth,
                Period(options, kFacade)),
        pillars_(kPillars, options.seed, options.image_width / kRefImageWidth,
                 Period(options, kPillars)) {}

  // JPEG bytes of location `index`. Throws cv::Exception if OpenCV fails.
  std::string Render(int index) {
    const Camera camera = CameraFor(options_, pass_, index);
    const cv::Size size(options_.image_width, options_.image_height);
    cv::Mat image =
        Composite(RenderPlane(camera, size, &facade_), RenderPlane(camera, size, &pillars_));
    return Encode(ApplySensor(image, index));
  }

 private:
  // The plane's period in tiles (0 = none): repeat_blocks blocks of kBlockMetres.
  static int64_t Period(const TourOptions& options, const Plane& plane) {
    return std::llround(options.repeat_blocks * kBlockMetres / plane.tile_metres);
  }

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
    // The generator's own image and quality: an encoding error is a bug, not an input.
    StatusOr<std::string> bytes = EncodeJpeg(image, options_.jpeg_quality);
    SCENELOC_CHECK(bytes.ok()) << bytes.status().ToString();
    return *std::move(bytes);
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

Status WriteTour(const TourOptions& options, const std::string& dir, int pass, int threads) {
  SCENELOC_RETURN_IF_ERROR(CheckArguments(options, pass));
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error || !std::filesystem::is_directory(dir)) {
    return IoError("cannot create directory '" + dir + "'" +
                   (error ? ": " + error.message() : std::string()));
  }
  // Each thread renders a contiguous run of locations with a renderer of its own (a
  // renderer caches the scene tiles its neighbouring locations share).
  const int count = std::clamp(threads, 1, std::max(1, options.num_locations));
  std::vector<Status> results(static_cast<size_t>(count));
  const auto render = [&](int part) {
    const int begin = static_cast<int>(static_cast<int64_t>(options.num_locations) * part / count);
    const int end =
        static_cast<int>(static_cast<int64_t>(options.num_locations) * (part + 1) / count);
    try {
      PassRenderer renderer(options, pass);
      for (int i = begin; i < end; ++i) {
        const Status written =
            WriteFile(std::filesystem::path(dir) / TourImageName(i), renderer.Render(i));
        if (!written.ok()) {
          results[static_cast<size_t>(part)] = written;
          return;
        }
      }
    } catch (const cv::Exception& e) {
      results[static_cast<size_t>(part)] =
          Internal(std::string("OpenCV failed while rendering a tour: ") + e.what());
    }
  };
  std::vector<std::thread> workers;
  for (int part = 1; part < count; ++part) workers.emplace_back(render, part);
  render(0);
  for (std::thread& t : workers) t.join();
  for (const Status& s : results) SCENELOC_RETURN_IF_ERROR(s);
  return Status::Ok();
}

}  // namespace sceneloc
