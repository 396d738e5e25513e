#include "common/features/extractor.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace sceneloc {

Status ExtractorOptions::Validate() const {
  if (max_features < 0) return InvalidArgument("max_features must be >= 0 (0 = no cap)");
  if (working_size < 64 || working_size > 4096) {
    return InvalidArgument("working_size must be in [64, 4096]");
  }
  if (!(context_scale > 1.0 && context_scale <= 8.0)) {
    return InvalidArgument("context_scale must be in (1, 8]");
  }
  if (!(contrast_threshold > 0.0)) return InvalidArgument("contrast_threshold must be > 0");
  if (!(edge_threshold > 0.0)) return InvalidArgument("edge_threshold must be > 0");
  if (!(sigma > 0.0)) return InvalidArgument("sigma must be > 0");
  if (!(clahe_clip >= 0.0 && clahe_clip <= 100.0)) {
    return InvalidArgument("clahe_clip must be in [0, 100]");
  }
  if (max_image_side < kMinImageSide) return InvalidArgument("max_image_side must be >= 16");
  SCENELOC_RETURN_IF_ERROR(holistic.Validate());
  return Status::Ok();
}

ExtractionTarget TourTarget(int width, int height, const ExtractorOptions& options) {
  const double scale =
      std::min(kMaxUpscale, static_cast<double>(options.working_size) / std::max(width, height));
  ExtractionTarget t;
  t.width = std::max(1, static_cast<int>(std::lround(width * scale)));
  t.height = std::max(1, static_cast<int>(std::lround(height * scale)));
  t.holistic = GridForFrame(t.width, t.height, options.holistic);
  return t;
}

ExtractionTarget QueryTarget(int width, int height, int map_width, const HolisticGrid& map_grid) {
  const double scale = static_cast<double>(map_width) / width;
  ExtractionTarget t;
  t.width = map_width;
  t.height = std::max(1, static_cast<int>(std::lround(height * scale)));
  t.holistic = map_grid;
  return t;
}

StatusOr<FeatureSet> FeatureExtractor::ExtractTour(const cv::Mat& image) const {
  if (image.empty()) return InvalidArgument("empty image");
  return Extract(image, TourTarget(image.cols, image.rows, options()));
}

namespace {

// L2-normalises each row; an all-zero row stays zero.
void NormaliseRows(DescriptorMatrix* m) {
  for (Eigen::Index i = 0; i < m->rows(); ++i) {
    const float norm = m->row(i).norm();
    if (norm > 0) m->row(i) /= norm;
  }
}

// RootSIFT (Arandjelovic & Zisserman 2012): each row L1-normalised and square-rooted, so
// that Euclidean distance compares descriptors by the Hellinger kernel. Rows stay unit L2.
void RootRows(DescriptorMatrix* m) {
  for (Eigen::Index i = 0; i < m->rows(); ++i) {
    const float l1 = m->row(i).cwiseAbs().sum();
    if (l1 > 0) m->row(i) = (m->row(i).cwiseAbs() / l1).cwiseSqrt();
  }
}

class SiftExtractor final : public FeatureExtractor {
 public:
  explicit SiftExtractor(const ExtractorOptions& options) : options_(options) {}

  const ExtractorOptions& options() const override { return options_; }

  StatusOr<FeatureSet> Extract(const cv::Mat& image,
                               const ExtractionTarget& target) const override {
    if (image.empty()) return InvalidArgument("empty image");
    if (image.depth() != CV_8U) return InvalidArgument("image must be 8-bit");
    const std::string size = std::to_string(image.cols) + "x" + std::to_string(image.rows);
    if (image.cols > options_.max_image_side || image.rows > options_.max_image_side) {
      return ResourceExhausted("image is " + size + ", larger than max_image_side " +
                               std::to_string(options_.max_image_side));
    }
    if (image.cols < kMinImageSide || image.rows < kMinImageSide) {
      return InvalidArgument("image is " + size + ", too small to hold features (at least " +
                             std::to_string(kMinImageSide) + " pixels per side)");
    }
    if (target.width < kMinImageSide || target.height < kMinImageSide ||
        target.width > options_.max_image_side || target.height > options_.max_image_side) {
      return InvalidArgument("image of " + size + " maps to a working frame of " +
                             std::to_string(target.width) + "x" + std::to_string(target.height) +
                             ", outside [" + std::to_string(kMinImageSide) + ", " +
                             std::to_string(options_.max_image_side) + "] pixels per side");
    }
    try {
      return ExtractOrThrow(image, target);
    } catch (const cv::Exception& e) {
      return Internal(std::string("OpenCV failed during extraction: ") + e.what());
    }
  }

 private:
  FeatureSet ExtractOrThrow(const cv::Mat& image, const ExtractionTarget& target) const {
    cv::Mat gray = ToGray(image);
    if (gray.cols != target.width || gray.rows != target.height) {
      cv::Mat scaled;
      const bool shrink = target.width <= gray.cols && target.height <= gray.rows;
      cv::resize(gray, scaled, cv::Size(target.width, target.height), 0, 0,
                 shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
      gray = scaled;
    }
    const cv::Mat holistic_source = gray;
    if (options_.clahe_clip > 0) {
      cv::Mat equalised;
      cv::createCLAHE(options_.clahe_clip, cv::Size(8, 8))->apply(gray, equalised);
      gray = equalised;
    }
    // cv::SIFT holds per-call scratch state, so each call makes its own (cheap).
    auto sift = cv::SIFT::create(options_.max_features, 3, options_.contrast_threshold,
                                 options_.edge_threshold, options_.sigma);
    std::vector<cv::KeyPoint> detected;
    sift->detect(gray, detected);
    if (options_.max_features > 0 && static_cast<int>(detected.size()) > options_.max_features) {
      // SIFT's own cap keeps ties beyond the limit; enforce it exactly.
      cv::KeyPointsFilter::retainBest(detected, options_.max_features);
      detected.resize(options_.max_features);
    }
    // Local and context keypoints in one compute call: the Gaussian pyramid is built
    // once and both descriptors are read off it.
    const size_t n = detected.size();
    std::vector<cv::KeyPoint> both(detected);
    both.reserve(2 * n);
    for (size_t i = 0; i < n; ++i) {
      cv::KeyPoint wide = detected[i];
      wide.size = static_cast<float>(wide.size * options_.context_scale);
      both.push_back(wide);
    }
    cv::Mat descriptors;
    sift->compute(gray, both, descriptors);
    // SIFT::compute keeps provided keypoints one-to-one; check rather than assume.
    CV_Assert(both.size() == 2 * n && descriptors.rows == static_cast<int>(2 * n));

    FeatureSet set;
    set.image_width = gray.cols;
    set.image_height = gray.rows;
    set.keypoints.resize(n);
    set.local.resize(static_cast<Eigen::Index>(n), kDescriptorSize);
    set.context.resize(static_cast<Eigen::Index>(n), kDescriptorSize);
    for (size_t i = 0; i < n; ++i) {
      const cv::KeyPoint& k = detected[i];
      set.keypoints[i] = {k.pt.x, k.pt.y, k.size, k.angle, k.response, k.octave};
      const float* local = descriptors.ptr<float>(static_cast<int>(i));
      const float* context = descriptors.ptr<float>(static_cast<int>(n + i));
      std::copy(local, local + kDescriptorSize, set.local.row(static_cast<Eigen::Index>(i)).data());
      std::copy(context, context + kDescriptorSize,
                set.context.row(static_cast<Eigen::Index>(i)).data());
    }
    if (options_.root_sift) {
      RootRows(&set.local);
      RootRows(&set.context);
    } else {
      NormaliseRows(&set.local);
      NormaliseRows(&set.context);
    }
    if (!target.holistic.empty()) {
      set.holistic_grid = target.holistic;
      set.holistic =
          ComputeHolistic(holistic_source, target.holistic, options_.holistic.cell_pixels);
    }
    return set;
  }

  static cv::Mat ToGray(const cv::Mat& image) {
    if (image.channels() == 1) return image;
    cv::Mat gray;
    cv::cvtColor(image, gray, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
    return gray;
  }

  const ExtractorOptions options_;
};

}  // namespace

std::unique_ptr<FeatureExtractor> FeatureExtractor::Create(const ExtractorOptions& options) {
  return std::make_unique<SiftExtractor>(options);
}

StatusOr<cv::Mat> ReadImageFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return NotFound("'" + path + "' is not a readable file");
  }
  cv::Mat image;
  try {
    image = cv::imread(path, cv::IMREAD_COLOR);
  } catch (const cv::Exception& e) {
    return InvalidArgument("'" + path + "' could not be decoded: " + e.what());
  }
  if (image.empty()) return InvalidArgument("'" + path + "' is not a readable image");
  return image;
}

StatusOr<cv::Mat> DecodeImage(const std::string& bytes, int max_image_side) {
  if (bytes.empty()) return InvalidArgument("image bytes are empty");
  cv::Mat image;
  try {
    const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data()));
    image = cv::imdecode(buffer, cv::IMREAD_COLOR);
  } catch (const cv::Exception& e) {
    return InvalidArgument(std::string("image bytes could not be decoded: ") + e.what());
  }
  if (image.empty()) return InvalidArgument("image bytes are not a decodable JPEG or PNG");
  if (image.cols > max_image_side || image.rows > max_image_side) {
    return ResourceExhausted("image is larger than " + std::to_string(max_image_side) +
                             " pixels per side");
  }
  return image;
}

}  // namespace sceneloc
