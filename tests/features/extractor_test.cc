#include "common/features/extractor.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "common/synthetic/tour_generator.h"

namespace sceneloc {
namespace {

// A tour frame's long side is working_size, whatever the image; small images are enlarged
// at most kMaxUpscale times.
TEST(ExtractorTest, TourTargetSetsTheLongSide) {
  ExtractorOptions o;
  const ExtractionTarget hd = TourTarget(960, 540, o);
  EXPECT_EQ(hd.width, 480);
  EXPECT_EQ(hd.height, 270);
  EXPECT_TRUE((hd.holistic == HolisticGrid{16, 9, 12}));
  const ExtractionTarget fisheye = TourTarget(160, 120, o);
  EXPECT_EQ(fisheye.width, 480);
  EXPECT_EQ(fisheye.height, 360);
  const ExtractionTarget portrait = TourTarget(300, 600, o);
  EXPECT_EQ(portrait.width, 240);
  EXPECT_EQ(portrait.height, 480);
  const ExtractionTarget tiny = TourTarget(40, 30, o);
  EXPECT_EQ(tiny.width, 160);  // 4x, not 12x
  EXPECT_EQ(tiny.height, 120);
}

// A query is brought to the map frame's width with its own aspect, on the map's grid.
TEST(ExtractorTest, QueryTargetMatchesTheMapWidth) {
  const HolisticGrid grid{16, 9, 12};
  const ExtractionTarget night = QueryTarget(640, 360, 480, grid);
  EXPECT_EQ(night.width, 480);
  EXPECT_EQ(night.height, 270);
  EXPECT_TRUE(night.holistic == grid);
  const ExtractionTarget four_three = QueryTarget(1024, 768, 480, grid);
  EXPECT_EQ(four_three.width, 480);
  EXPECT_EQ(four_three.height, 360);
  EXPECT_TRUE(four_three.holistic == grid);  // the map's grid, whatever the aspect
}

// Extraction happens in the target frame: keypoints inside it, the holistic descriptor on
// the target grid, descriptors of unit norm.
TEST(ExtractorTest, ExtractsInTheTargetFrame) {
  TourOptions tour;
  tour.num_locations = 1;
  auto jpegs = RenderTourJpegs(tour, kTrainingPass);
  ASSERT_TRUE(jpegs.ok());
  auto image = DecodeImage((*jpegs)[0], 4096);
  ASSERT_TRUE(image.ok());
  const auto extractor = FeatureExtractor::Create({});
  auto f = extractor->ExtractTour(*image);
  ASSERT_TRUE(f.ok()) << f.status().ToString();
  EXPECT_EQ(f->image_width, 480);
  EXPECT_EQ(f->image_height, 270);
  EXPECT_GT(f->size(), 100);
  for (const Keypoint& k : f->keypoints) {
    EXPECT_GE(k.x, 0);
    EXPECT_LT(k.x, 480);
    EXPECT_GE(k.y, 0);
    EXPECT_LT(k.y, 270);
  }
  EXPECT_NEAR(f->local.row(0).norm(), 1.0f, 1e-4);
  EXPECT_NEAR(f->context.row(0).norm(), 1.0f, 1e-4);
  EXPECT_TRUE((f->holistic_grid == HolisticGrid{16, 9, 12}));
  EXPECT_EQ(f->holistic.size(), 16u * 9 * 12);
}

// A generated 960x540 tour frame and its 480x270 grey working frame, as the extractor
// makes it.
struct Frame {
  cv::Mat image;
  cv::Mat gray;
};

Frame TourFrame() {
  TourOptions tour;
  tour.num_locations = 1;
  auto jpegs = RenderTourJpegs(tour, kTrainingPass);
  EXPECT_TRUE(jpegs.ok());
  auto image = DecodeImage((*jpegs)[0], 4096);
  EXPECT_TRUE(image.ok());
  Frame f{*image, {}};
  cv::Mat gray;
  cv::cvtColor(f.image, gray, cv::COLOR_BGR2GRAY);
  cv::resize(gray, f.gray, cv::Size(480, 270), 0, 0, cv::INTER_AREA);
  return f;
}

float Cosine(const float* a, const float* b) {
  double ab = 0, aa = 0, bb = 0;
  for (int i = 0; i < kDescriptorSize; ++i) {
    ab += a[i] * b[i];
    aa += a[i] * a[i];
    bb += b[i] * b[i];
  }
  return aa > 0 && bb > 0 ? static_cast<float>(ab / std::sqrt(aa * bb)) : 0.f;
}

// The keypoints and local descriptors are exactly plain SIFT's (detectAndCompute on the
// working frame, the latency floor): one pyramid, nothing changed in meaning. With the
// default 3 scale levels per octave and with another (a map stores which).
TEST(ExtractorTest, LocalDescriptorsArePlainSift) {
  const Frame frame = TourFrame();
  for (const int layers : {3, 5}) {
    ExtractorOptions o;
    o.octave_layers = layers;
    auto f = FeatureExtractor::Create(o)->ExtractTour(frame.image);
    ASSERT_TRUE(f.ok()) << f.status().ToString();
    auto sift =
        cv::SIFT::create(o.max_features, layers, o.contrast_threshold, o.edge_threshold, o.sigma);
    std::vector<cv::KeyPoint> k;
    cv::Mat d;
    sift->detectAndCompute(frame.gray, cv::noArray(), k, d);
    ASSERT_GT(f->size(), 100) << layers;
    ASSERT_LE(f->size(), static_cast<int>(k.size())) << layers;
    // Each of ours is one of SIFT's, at the same point, scale and angle (up to the last bits
    // of the sub-pixel fit: sift_detector_test.cc), same descriptor.
    int same = 0;
    for (int i = 0; i < f->size(); ++i) {
      const Keypoint& p = f->keypoints[static_cast<size_t>(i)];
      for (size_t j = 0; j < k.size(); ++j) {
        if (std::abs(k[j].pt.x - p.x) < 1e-3f && std::abs(k[j].pt.y - p.y) < 1e-3f &&
            std::abs(k[j].size - p.size) < 1e-4f * p.size &&
            std::abs(k[j].angle - p.angle) < 0.1f) {
          same += Cosine(f->local.row(i).data(), d.ptr<float>(static_cast<int>(j))) > 0.9999f;
          break;
        }
      }
    }
    // A keypoint in a few hundred may flip a threshold or an orientation peak there.
    EXPECT_GE(same, 0.99 * f->size()) << layers;
  }
}

// The context descriptor is the paper's: the same point described at twice its size. It is
// read one octave up (the window at the blur of its own scale) where the old extractor
// read it on the keypoint's octave; the two agree closely, and both differ from the local
// descriptor. A wrongly packed octave or a lost scale drops the agreement.
TEST(ExtractorTest, ContextIsThePointAtTwiceTheSize) {
  const Frame frame = TourFrame();
  for (const int layers : {3, 5}) {
    ExtractorOptions o;
    o.octave_layers = layers;
    auto f = FeatureExtractor::Create(o)->ExtractTour(frame.image);
    ASSERT_TRUE(f.ok()) << f.status().ToString();
    std::vector<cv::KeyPoint> wide;
    for (const Keypoint& p : f->keypoints) {
      wide.emplace_back(cv::Point2f(p.x, p.y), p.size * 2, p.angle, p.response, p.octave);
    }
    cv::Mat same_octave;
    cv::SIFT::create(o.max_features, layers, o.contrast_threshold, o.edge_threshold, o.sigma)
        ->compute(frame.gray, wide, same_octave);
    ASSERT_EQ(same_octave.rows, f->size());
    double to_same_octave = 0, to_local = 0;
    for (int i = 0; i < f->size(); ++i) {
      to_same_octave += Cosine(f->context.row(i).data(), same_octave.ptr<float>(i));
      to_local += Cosine(f->context.row(i).data(), f->local.row(i).data());
    }
    to_same_octave /= f->size();
    to_local /= f->size();
    EXPECT_GT(to_same_octave, 0.85) << layers << " layers, local " << to_local;
    EXPECT_LT(to_local, to_same_octave - 0.1) << layers;
  }
}

// How many of `f`'s context descriptors agree (cosine above 0.999) with OpenCV's
// SIFT::compute of its context keypoints.
int ContextRowsLikeSifts(const Frame& frame, const FeatureSet& f, const ExtractorOptions& o) {
  std::vector<cv::KeyPoint> wide = ContextKeypoints(f, o);
  cv::Mat sift;
  cv::SIFT::create(o.max_features, o.octave_layers, o.contrast_threshold, o.edge_threshold, o.sigma)
      ->compute(frame.gray, wide, sift);
  EXPECT_EQ(sift.rows, f.size());
  int close = 0;
  for (int i = 0; i < std::min(f.size(), sift.rows); ++i) {
    close += Cosine(f.context.row(i).data(), sift.ptr<float>(i)) > 0.999f;
  }
  return close;
}

// The context descriptors are SIFT's own descriptors of the context keypoints, though read
// from a pyramid of their own (sift_describer.h): OpenCV's SIFT::compute of the same points
// agrees with each of them.
TEST(ExtractorTest, ContextDescriptorsAreSiftsOfTheContextKeypoints) {
  const Frame frame = TourFrame();
  for (const int layers : {3, 5}) {
    ExtractorOptions o;
    o.octave_layers = layers;
    auto f = FeatureExtractor::Create(o)->ExtractTour(frame.image);
    ASSERT_TRUE(f.ok()) << f.status().ToString();
    EXPECT_GE(ContextRowsLikeSifts(frame, *f, o), f->size() * 99 / 100) << layers << " layers";
  }
}

// Below twice the size some context keypoints stay on SIFT's doubled base, which only
// SIFT's own pyramid has: those frames are described by SIFT::compute, the same points.
TEST(ExtractorTest, ContextBelowTwiceTheSizeIsSiftsToo) {
  const Frame frame = TourFrame();
  ExtractorOptions o;
  o.context_scale = 1.5;
  auto f = FeatureExtractor::Create(o)->ExtractTour(frame.image);
  ASSERT_TRUE(f.ok()) << f.status().ToString();
  const std::vector<cv::KeyPoint> wide = ContextKeypoints(*f, o);
  ASSERT_TRUE(std::any_of(wide.begin(), wide.end(), [](const cv::KeyPoint& k) {
    return static_cast<int8_t>(k.octave & 0xff) < 0;
  }));
  EXPECT_GE(ContextRowsLikeSifts(frame, *f, o), f->size() * 99 / 100);
}

// max_features is exact and keeps the strongest responses.
TEST(ExtractorTest, KeepsExactlyTheStrongest) {
  const Frame frame = TourFrame();
  ExtractorOptions all;
  all.max_features = 0;
  ExtractorOptions capped;
  capped.max_features = 50;
  auto every = FeatureExtractor::Create(all)->ExtractTour(frame.image);
  auto few = FeatureExtractor::Create(capped)->ExtractTour(frame.image);
  ASSERT_TRUE(every.ok() && few.ok());
  ASSERT_GT(every->size(), 50);
  ASSERT_EQ(few->size(), 50);
  std::vector<float> responses;
  for (const Keypoint& k : every->keypoints) responses.push_back(k.response);
  std::sort(responses.rbegin(), responses.rend());
  for (const Keypoint& k : few->keypoints) EXPECT_GE(k.response, responses[49]);
}

// Frames at the smallest working sizes still extract (the context octave stays inside
// the small pyramid).
TEST(ExtractorTest, ExtractsTinyFrames) {
  const Frame frame = TourFrame();
  const auto extractor = FeatureExtractor::Create({});
  for (const cv::Size size : {cv::Size(16, 16), cv::Size(16, 300), cv::Size(40, 23)}) {
    ExtractionTarget target;
    target.width = size.width;
    target.height = size.height;
    auto f = extractor->Extract(frame.image, target);
    ASSERT_TRUE(f.ok()) << size << ": " << f.status().ToString();
    EXPECT_EQ(f->local.rows(), f->context.rows());
  }
}

// A JPEG decodes at the largest DCT reduction that still covers the working frame, so the
// extractor only ever shrinks it.
TEST(ExtractorTest, DecodeReductionKeepsTheFrameCovered) {
  ExtractionTarget t;
  t.width = 480;
  t.height = 270;
  EXPECT_EQ(DecodeReduction(960, 540, t), 2);
  EXPECT_EQ(DecodeReduction(1920, 1080, t), 4);
  EXPECT_EQ(DecodeReduction(8000, 4500, t), 8);  // never beyond libjpeg's 1/8
  EXPECT_EQ(DecodeReduction(959, 540, t), 1);    // half would be 479 wide
  EXPECT_EQ(DecodeReduction(640, 360, t), 1);
  EXPECT_EQ(DecodeReduction(160, 120, t), 1);  // enlarged, never reduced
  ExtractionTarget tiny;
  tiny.width = 8;
  tiny.height = 8;
  EXPECT_EQ(DecodeReduction(960, 540, tiny), 1);  // an invalid frame is left to Extract
}

TEST(ExtractorTest, DecodeGrayAtReducedSize) {
  TourOptions tour;
  tour.num_locations = 1;
  tour.image_width = 960;
  tour.image_height = 540;
  auto jpegs = RenderTourJpegs(tour, kTrainingPass);
  ASSERT_TRUE(jpegs.ok());
  for (const int r : {1, 2, 4, 8}) {
    auto g = DecodeGray((*jpegs)[0], 8192, r);
    ASSERT_TRUE(g.ok()) << r << ": " << g.status().ToString();
    EXPECT_EQ(g->channels(), 1);
    EXPECT_EQ(g->cols, (960 + r - 1) / r);
    EXPECT_EQ(g->rows, (540 + r - 1) / r);
  }
  EXPECT_EQ(DecodeGray((*jpegs)[0], 8192, 3).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(DecodeGray("not a jpeg", 8192, 2).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(DecodeGray((*jpegs)[0], 400, 2).status().code(), StatusCode::kResourceExhausted);
  // The reduced frame gives the features the full decode gives, up to resampling.
  const ExtractionTarget target = TourTarget(960, 540, {});
  const auto extractor = FeatureExtractor::Create({});
  auto full = extractor->Extract(*DecodeImage((*jpegs)[0], 8192), target);
  auto reduced = extractor->Extract(*DecodeGray((*jpegs)[0], 8192, 2), target);
  ASSERT_TRUE(full.ok() && reduced.ok());
  EXPECT_NEAR(reduced->size(), full->size(), full->size() / 5);
}

// Images too small, too large or empty are refused with a clear status, never a crash.
TEST(ExtractorTest, RefusesUnusableImages) {
  const auto extractor = FeatureExtractor::Create({});
  for (const cv::Size size :
       {cv::Size(1, 1), cv::Size(4, 4), cv::Size(4096, 1), cv::Size(15, 40)}) {
    auto f = extractor->ExtractTour(cv::Mat(size, CV_8UC3, cv::Scalar(100, 100, 100)));
    ASSERT_FALSE(f.ok()) << size;
    EXPECT_EQ(f.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(f.status().message().find("too small"), std::string::npos) << f.status().message();
  }
  ExtractorOptions small_cap;
  small_cap.max_image_side = 100;
  auto big = FeatureExtractor::Create(small_cap)->ExtractTour(cv::Mat(200, 200, CV_8UC1));
  EXPECT_EQ(big.status().code(), StatusCode::kResourceExhausted);
  EXPECT_FALSE(extractor->ExtractTour(cv::Mat()).ok());
  // A flat image is a valid frame without keypoints.
  auto flat = extractor->ExtractTour(cv::Mat(120, 160, CV_8UC1, cv::Scalar(50)));
  ASSERT_TRUE(flat.ok());
  EXPECT_EQ(flat->size(), 0);
}

// The default options are valid; each field out of its range is refused, naming it.
TEST(ExtractorTest, OptionsOutOfRangeAreRefused) {
  EXPECT_TRUE(ExtractorOptions().Validate().ok());
  struct Case {
    void (*set)(ExtractorOptions*);
    const char* field;
  };
  const Case cases[] = {
      {[](ExtractorOptions* o) { o->max_features = -1; }, "max_features"},
      {[](ExtractorOptions* o) { o->working_size = 63; }, "working_size"},
      {[](ExtractorOptions* o) { o->context_scale = 1.0; }, "context_scale"},
      {[](ExtractorOptions* o) { o->contrast_threshold = 0; }, "contrast_threshold"},
      {[](ExtractorOptions* o) { o->edge_threshold = -1; }, "edge_threshold"},
      {[](ExtractorOptions* o) { o->sigma = 0; }, "sigma"},
      {[](ExtractorOptions* o) { o->octave_layers = 0; }, "octave_layers"},
      {[](ExtractorOptions* o) { o->clahe_clip = 101; }, "clahe_clip"},
      {[](ExtractorOptions* o) { o->max_image_side = 15; }, "max_image_side"},
  };
  for (const Case& c : cases) {
    ExtractorOptions o;
    c.set(&o);
    const Status status = o.Validate();
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << c.field;
    EXPECT_NE(status.message().find(c.field), std::string::npos) << status.message();
  }
}

// RootSIFT rows are the square roots of the plain rows' L1-normalised values: unit L2,
// non-negative, on the same keypoints.
TEST(ExtractorTest, RootSiftIsTheRootOfTheL1NormalisedRow) {
  const Frame frame = TourFrame();
  ExtractorOptions root;
  root.root_sift = true;
  auto plain = FeatureExtractor::Create({})->ExtractTour(frame.image);
  auto rooted = FeatureExtractor::Create(root)->ExtractTour(frame.image);
  ASSERT_TRUE(plain.ok() && rooted.ok());
  ASSERT_EQ(plain->size(), rooted->size());
  ASSERT_GT(plain->size(), 0);
  for (int i = 0; i < plain->size(); i += 17) {
    const auto p = plain->local.row(i);
    const auto r = rooted->local.row(i);
    EXPECT_NEAR(r.norm(), 1.0f, 1e-4);
    for (int j = 0; j < kDescriptorSize; ++j) {
      EXPECT_NEAR(r(j), std::sqrt(p(j) / p.sum()), 1e-4) << "row " << i << ", value " << j;
    }
  }
}

// Local contrast equalisation changes what SIFT sees but not the holistic descriptor,
// which is taken from the frame before it.
TEST(ExtractorTest, EqualisationLeavesTheHolisticDescriptor) {
  const Frame frame = TourFrame();
  ExtractorOptions clahe;
  clahe.clahe_clip = 4;
  auto plain = FeatureExtractor::Create({})->ExtractTour(frame.image);
  auto equalised = FeatureExtractor::Create(clahe)->ExtractTour(frame.image);
  ASSERT_TRUE(plain.ok() && equalised.ok());
  EXPECT_EQ(plain->holistic, equalised->holistic);
  EXPECT_FALSE(plain->size() == equalised->size() && plain->local.isApprox(equalised->local));
}

// An image that is not 8-bit is refused.
TEST(ExtractorTest, RefusesImagesThatAreNot8Bit) {
  auto f = FeatureExtractor::Create({})->ExtractTour(cv::Mat(100, 100, CV_16UC1, cv::Scalar(9)));
  EXPECT_EQ(f.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(f.status().message().find("8-bit"), std::string::npos);
}

// Decoding refuses empty bytes, bytes that are no image, images over the side limit and a
// reduction other than 1, 2, 4 or 8; reading refuses a missing file.
TEST(ExtractorTest, DecodeAndReadRefuseBadInput) {
  EXPECT_EQ(DecodeImage("", 4096).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(DecodeImage("definitely not a jpeg", 4096).status().code(),
            StatusCode::kInvalidArgument);
  TourOptions tour;
  tour.num_locations = 1;
  auto jpegs = RenderTourJpegs(tour, kTrainingPass);
  ASSERT_TRUE(jpegs.ok());
  EXPECT_EQ(DecodeImage((*jpegs)[0], 100).status().code(), StatusCode::kResourceExhausted);
  EXPECT_EQ(DecodeGray((*jpegs)[0], 4096, 3).status().code(), StatusCode::kInvalidArgument);
  const StatusOr<cv::Mat> gray = DecodeGray((*jpegs)[0], 4096, 1);
  ASSERT_TRUE(gray.ok());
  EXPECT_EQ(gray->channels(), 1);
  EXPECT_EQ(ReadImageFile("/nonexistent/image.jpg").status().code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace sceneloc
