#include "common/features/extractor.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "common/features/sift_describer.h"
#include "common/features/sift_detector.h"
#include "common/image/image_codec.h"
#include "common/util/file_io.h"

namespace sceneloc {

SettingTable ExtractorSettings(ExtractorOptions* o, const std::string& section) {
  SettingTable table = {
      Setting(section, "max_features", &o->max_features)
          .Range(1, 100000)
          .Off(0)
          .Help("strongest SIFT keypoints kept per image (0 = no cap)"),
      Setting(section, "working_size", &o->working_size)
          .Range(64, 4096)
          .Unit("pixels")
          .Help("long side of the working frame (960x540 -> 480x270, 160x120 -> 480x360)"),
      Setting(section, "context_scale", &o->context_scale)
          .Range(1.01, 8)
          .Help("context descriptor size / keypoint size (paper: 2)"),
      Setting(section, "contrast_threshold", &o->contrast_threshold)
          .Range(1e-6, 1)
          .Help("OpenCV SIFT defaults (0.02 measured no better, slower)"),
      Setting(section, "edge_threshold", &o->edge_threshold).Range(1e-6, 1000),
      Setting(section, "sigma", &o->sigma).Range(0.1, 10).Unit("pixels"),
      Setting(section, "octave_layers", &o->octave_layers)
          .Range(1, 8)
          .Help("SIFT scale levels per octave (OpenCV's and Lowe's: 3)"),
      Setting(section, "clahe_clip", &o->clahe_clip)
          .Range(0, 100)
          .Help("local contrast equalisation before SIFT (0 = off; measured, not better)"),
      Setting(section, "root_sift", &o->root_sift)
          .Help("RootSIFT descriptors (measured, not better on every set)"),
      Setting(section, "max_image_side", &o->max_image_side)
          .Range(kMinImageSide, kMaxImageSideSetting)
          .Unit("pixels")
          .Help("larger images are refused"),
  };
  for (SettingField& f : HolisticSettings(&o->holistic, section)) table.push_back(std::move(f));
  return table;
}

Status ExtractorOptions::Validate() const {
  ExtractorOptions copy = *this;
  SCENELOC_RETURN_IF_ERROR(CheckSettings(ExtractorSettings(&copy)));
  return holistic.Validate();
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

// RootSIFT (Arandjelovic & Zisserman 2012): each row L1-normalised and square-rooted, so
// that Euclidean distance compares descriptors by the Hellinger kernel. Rows stay unit L2.
void RootRows(DescriptorMatrix* m) {
  for (Eigen::Index i = 0; i < m->rows(); ++i) {
    const float l1 = m->row(i).cwiseAbs().sum();
    if (l1 > 0) m->row(i) = (m->row(i).cwiseAbs() / l1).cwiseSqrt();
  }
}

// OpenCV's SIFT packs a keypoint's pyramid octave into the low byte of KeyPoint::octave
// (signed: -1 is the doubled base image), its layer in the octave into the next byte and
// a sub-layer offset above.
int UnpackOctave(const cv::KeyPoint& k) { return static_cast<int8_t>(k.octave & 0xff); }

// The highest octave a context descriptor is read from in a frame of w x h: the one whose
// image is still at least 8 pixels on its short side.
int TopContextOctave(int w, int h) {
  int octave = 0;
  while ((std::min(w, h) >> (octave + 1)) >= 8) ++octave;
  return octave;
}

// The context keypoint of `k`: the same point at `scale` times its size (the window the
// paper asks for), read off a higher octave of the pyramid. A SIFT keypoint's size doubles
// per octave, so one octave up (at the paper's scale 2) the window covers the same number
// of pixels as the local one: a quarter of what the same window costs on k's own octave,
// where a two-pass extractor would read it. Of the octave's images, the least blurred
// (layer 0: the blur of k's octave's top layer, halved in resolution) keeps the blur
// closest to that old descriptor's; the layer of k's own blur one octave up measured
// slightly worse (docs/results.md, "One pass of extraction"). Octaves up = floor(log2
// scale); the octave stays at most `top` (above it the image is too small to describe).
cv::KeyPoint ContextKeypoint(const cv::KeyPoint& k, double scale, int top, int octave_layers) {
  cv::KeyPoint wide = k;
  wide.size = static_cast<float>(k.size * scale);
  const int own = UnpackOctave(k);
  const int up =
      std::max(0, std::min(static_cast<int>(std::floor(std::log2(scale) + 1e-9)), top - own));
  const int layer = std::max(0, ((k.octave >> 8) & 0xff) - octave_layers * up);
  wide.octave = (k.octave & ~0xffff) | ((layer & 0xff) << 8) | ((own + up) & 0xff);
  return wide;
}

// The indices of the at most max_features (0 = all) strongest keypoints, in detection
// order. SIFT's own cap keeps ties at the limit; this one is exact and deterministic.
std::vector<int> StrongestFirst(const std::vector<cv::KeyPoint>& k, int max_features) {
  std::vector<int> order(k.size());
  for (size_t i = 0; i < k.size(); ++i) order[i] = static_cast<int>(i);
  if (max_features <= 0 || static_cast<int>(k.size()) <= max_features) return order;
  std::stable_sort(order.begin(), order.end(),
                   [&k](int a, int b) { return k[a].response > k[b].response; });
  order.resize(max_features);
  std::sort(order.begin(), order.end());
  return order;
}

cv::Mat ToGray(const cv::Mat& image) {
  if (image.channels() == 1) return image;
  cv::Mat gray;
  cv::cvtColor(image, gray, image.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return gray;
}

// The image in grey at the target's size: the frame features are extracted in.
cv::Mat WorkingFrame(const cv::Mat& image, const ExtractionTarget& target) {
  cv::Mat gray = ToGray(image);
  if (gray.cols != target.width || gray.rows != target.height) {
    cv::Mat scaled;
    const bool shrink = target.width <= gray.cols && target.height <= gray.rows;
    cv::resize(gray, scaled, cv::Size(target.width, target.height), 0, 0,
               shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
    gray = scaled;
  }
  return gray;
}

// Local contrast equalisation (CLAHE) of a grey frame.
cv::Mat Equalise(const cv::Mat& gray, double clip) {
  cv::Mat equalised;
  cv::createCLAHE(clip, cv::Size(8, 8))->apply(gray, equalised);
  return equalised;
}

// The context descriptors of the kept keypoints, in their order: each keypoint at
// context_scale times its size, read off the pyramid octave that holds that scale
// (ContextKeypoint). At a context_scale of 2 or more no keypoint stays below octave 0, so
// their pyramid starts at the working frame itself, a quarter of the pixels of the
// detection pyramid's doubled base, and holds only the images they are read from, with
// each pixel's gradient computed once (sift_describer.h): the second pass costs little
// more than the histograms.
cv::Mat ContextDescriptors(const SiftParameters& sift, const cv::Mat& gray,
                           const std::vector<cv::KeyPoint>& detected, const std::vector<int>& kept,
                           double context_scale) {
  const int octave_layers = sift.octave_layers;
  const size_t n = kept.size();
  std::vector<cv::KeyPoint> wide;
  wide.reserve(n);
  const int top = TopContextOctave(gray.cols, gray.rows);
  for (const int i : kept)
    wide.push_back(ContextKeypoint(detected[i], context_scale, top, octave_layers));
  const bool above_base = std::all_of(wide.begin(), wide.end(),
                                      [](const cv::KeyPoint& k) { return UnpackOctave(k) >= 0; });
  cv::Mat context;
  if (above_base) {
    context = DescribeSiftKeypoints(gray, wide, octave_layers, sift.sigma);
  } else if (n > 0) {
    // Below 2x some stay on the doubled base, which only SIFT's own pyramid builds.
    cv::SIFT::create(sift.max_features, sift.octave_layers, sift.contrast_threshold,
                     sift.edge_threshold, sift.sigma)
        ->compute(gray, wide, context);
  }
  CV_Assert(wide.size() == n && context.rows == static_cast<int>(n));
  return context;
}

// The kept keypoints and their local (rows of `local` by detection index) and context
// (rows of `context` in kept order) descriptors, as a feature set of a frame of `size`.
FeatureSet PackFeatures(const std::vector<cv::KeyPoint>& detected, const std::vector<int>& kept,
                        const cv::Mat& local, const cv::Mat& context, const cv::Size& size) {
  const size_t n = kept.size();
  FeatureSet set;
  set.image_width = size.width;
  set.image_height = size.height;
  set.keypoints.resize(n);
  set.local.resize(static_cast<Eigen::Index>(n), kDescriptorSize);
  set.context.resize(static_cast<Eigen::Index>(n), kDescriptorSize);
  for (size_t j = 0; j < n; ++j) {
    const cv::KeyPoint& k = detected[kept[j]];
    set.keypoints[j] = {k.pt.x, k.pt.y, k.size, k.angle, k.response, k.octave};
    const float* l = local.ptr<float>(kept[j]);
    const float* c = context.ptr<float>(static_cast<int>(j));
    const auto row = static_cast<Eigen::Index>(j);
    std::copy(l, l + kDescriptorSize, set.local.row(row).data());
    std::copy(c, c + kDescriptorSize, set.context.row(row).data());
  }
  return set;
}

SiftParameters SiftParametersOf(const ExtractorOptions& options) {
  SiftParameters p;
  p.max_features = options.max_features;
  p.octave_layers = options.octave_layers;
  p.contrast_threshold = options.contrast_threshold;
  p.edge_threshold = options.edge_threshold;
  p.sigma = options.sigma;
  return p;
}

// Unit rows: RootSIFT when `root_sift`, else plain L2 normalisation.
void NormaliseDescriptors(bool root_sift, FeatureSet* set) {
  if (root_sift) {
    RootRows(&set->local);
    RootRows(&set->context);
  } else {
    NormaliseRows(&set->local);
    NormaliseRows(&set->context);
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
    const cv::Mat frame = WorkingFrame(image, target);
    const cv::Mat gray = options_.clahe_clip > 0 ? Equalise(frame, options_.clahe_clip) : frame;
    // Detection and the local descriptors from one pyramid: plain SIFT, with the pyramid
    // built on every core (sift_detector.h).
    const SiftParameters sift = SiftParametersOf(options_);
    std::vector<cv::KeyPoint> detected;
    cv::Mat local;
    DetectAndDescribeSift(gray, sift, &detected, &local);
    CV_Assert(local.rows == static_cast<int>(detected.size()));
    const std::vector<int> kept = StrongestFirst(detected, options_.max_features);
    const cv::Mat context = ContextDescriptors(sift, gray, detected, kept, options_.context_scale);
    FeatureSet set = PackFeatures(detected, kept, local, context, gray.size());
    NormaliseDescriptors(options_.root_sift, &set);
    if (!target.holistic.empty()) {
      // From the frame before equalisation.
      set.holistic_grid = target.holistic;
      set.holistic = ComputeHolistic(frame, target.holistic, options_.holistic.cell_pixels);
    }
    return set;
  }

  const ExtractorOptions options_;
};

}  // namespace

std::unique_ptr<FeatureExtractor> FeatureExtractor::Create(const ExtractorOptions& options) {
  return std::make_unique<SiftExtractor>(options);
}

std::vector<cv::KeyPoint> ContextKeypoints(const FeatureSet& set, const ExtractorOptions& options) {
  const int top = TopContextOctave(set.image_width, set.image_height);
  std::vector<cv::KeyPoint> wide;
  wide.reserve(set.keypoints.size());
  for (const Keypoint& k : set.keypoints) {
    const cv::KeyPoint detected(k.x, k.y, k.size, k.angle, k.response, k.octave);
    wide.push_back(ContextKeypoint(detected, options.context_scale, top, options.octave_layers));
  }
  return wide;
}

StatusOr<cv::Mat> ReadImageFile(const std::string& path) {
  SCENELOC_ASSIGN_OR_RETURN(const std::string bytes, ReadFileBytes(path));
  auto image = DecodeImageBytes(bytes, DecodeOptions{});
  if (!image.ok()) {
    return Status(image.status().code(),
                  "'" + path + "' is not a readable image: " + image.status().message());
  }
  return image;
}

StatusOr<cv::Mat> DecodeImage(const std::string& bytes, int max_image_side) {
  DecodeOptions options;
  options.max_side = max_image_side;
  return DecodeImageBytes(bytes, options);
}

int DecodeReduction(int width, int height, const ExtractionTarget& target) {
  int reduction = 1;
  if (target.width < kMinImageSide || target.height < kMinImageSide) return reduction;
  // libjpeg rounds a scaled size up, so width / (2 * reduction) rounded down is a safe
  // lower bound for the next step.
  while (reduction < 8 && width / (2 * reduction) >= target.width &&
         height / (2 * reduction) >= target.height) {
    reduction *= 2;
  }
  return reduction;
}

StatusOr<cv::Mat> DecodeGray(const std::string& bytes, int max_image_side, int reduction) {
  DecodeOptions options;
  options.gray = true;
  options.reduction = reduction;
  options.max_side = max_image_side;
  return DecodeImageBytes(bytes, options);
}

}  // namespace sceneloc
