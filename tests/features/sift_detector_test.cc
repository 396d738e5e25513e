#include "common/features/sift_detector.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "common/features/opencv_threads.h"
#include "common/util/thread_pool.h"
#include "sift_test_frames.h"

namespace sceneloc {
namespace {

// Grey frames of the generated tour at the extractor's working size (480x270) and at
// another shape and size (320x240: another octave count).
std::vector<cv::Mat> TourGrays() {
  return TourGrayFrames({cv::Size(480, 270), cv::Size(320, 240)});
}

struct Agreement {
  size_t ours = 0;
  size_t theirs = 0;
  double same = 0;        // share of OpenCV's keypoints we return equal in every field
  double close = 0;       // ... within 0.01 px, 0.1% in size and 0.1 degrees
  double equal_rows = 0;  // of the close keypoints, share with equal descriptors
  double min_cosine = 1;  // of the close keypoints' descriptors
};

Agreement CompareWithOpenCv(const cv::Mat& gray, const SiftParameters& p) {
  std::vector<cv::KeyPoint> ours;
  cv::Mat ours_d;
  DetectAndDescribeSift(gray, p, &ours, &ours_d);
  EXPECT_EQ(ours_d.rows, static_cast<int>(ours.size()));
  std::vector<cv::KeyPoint> theirs;
  cv::Mat theirs_d;
  cv::SIFT::create(p.max_features, p.octave_layers, p.contrast_threshold, p.edge_threshold, p.sigma)
      ->detectAndCompute(gray, cv::noArray(), theirs, theirs_d);
  Agreement a;
  a.ours = ours.size();
  a.theirs = theirs.size();
  std::multimap<std::tuple<int, int>, size_t> by_pixel;
  for (size_t i = 0; i < ours.size(); ++i) {
    by_pixel.emplace(std::make_tuple(cvRound(ours[i].pt.x), cvRound(ours[i].pt.y)), i);
  }
  size_t same = 0, close = 0, equal_rows = 0;
  for (size_t j = 0; j < theirs.size(); ++j) {
    const cv::KeyPoint& t = theirs[j];
    bool found_same = false, found_close = false;
    const auto range = by_pixel.equal_range(std::make_tuple(cvRound(t.pt.x), cvRound(t.pt.y)));
    for (auto it = range.first; it != range.second; ++it) {
      const cv::KeyPoint& o = ours[it->second];
      if (o.pt == t.pt && o.size == t.size && o.angle == t.angle && o.octave == t.octave &&
          o.response == t.response) {
        found_same = true;
      }
      if (!found_close && cv::norm(o.pt - t.pt) < 0.01 &&
          std::abs(o.size - t.size) < 1e-3 * t.size && std::abs(o.angle - t.angle) < 0.1f) {
        found_close = true;
        const int oi = static_cast<int>(it->second);
        const int ti = static_cast<int>(j);
        equal_rows += cv::norm(ours_d.row(oi), theirs_d.row(ti), cv::NORM_INF) == 0;
        a.min_cosine = std::min(a.min_cosine,
                                DescriptorCosine(ours_d.ptr<float>(oi), theirs_d.ptr<float>(ti)));
      }
    }
    same += found_same;
    close += found_close;
  }
  a.same = theirs.empty() ? 1 : static_cast<double>(same) / static_cast<double>(theirs.size());
  a.close = theirs.empty() ? 1 : static_cast<double>(close) / static_cast<double>(theirs.size());
  a.equal_rows = close == 0 ? 0 : static_cast<double>(equal_rows) / static_cast<double>(close);
  return a;
}

void Print(const char* what, const Agreement& a) {
  std::printf(
      "%s: ours %zu, OpenCV %zu, same %.4f, close %.4f, equal descriptors %.4f, "
      "lowest cosine %.6f\n",
      what, a.ours, a.theirs, a.same, a.close, a.equal_rows, a.min_cosine);
}

// The keypoints are OpenCV's: a lost layer, a misread octave, a wrong threshold or an
// orientation off by a bin would each lose far more than these allow. Most are equal to
// the bit in every field (OpenCV's rounding reproduced: OpenCvFusesMultiplyAdds in
// sift_detector.cc; without it about half are); the rest differ in the last bit of their
// size or response (a scale's power of two, rounded differently), rarely of an angle.
TEST(SiftDetectorTest, AgreesWithOpenCvSift) {
  for (const cv::Mat& gray : TourGrays()) {
    for (const int layers : {3, 4, 5}) {
      SiftParameters p;
      p.octave_layers = layers;
      const Agreement a = CompareWithOpenCv(gray, p);
      Print(("layers " + std::to_string(layers)).c_str(), a);
      ASSERT_GT(a.theirs, 300u);
      EXPECT_NEAR(static_cast<double>(a.ours), static_cast<double>(a.theirs), 0.01 * a.theirs);
      EXPECT_GT(a.same, 0.85);
      EXPECT_GT(a.close, 0.995);
      EXPECT_GT(a.equal_rows, 0.99);
      EXPECT_GT(a.min_cosine, 0.9999);
    }
  }
}

// The cap keeps the strongest, as OpenCV's does (ties at the limit kept).
TEST(SiftDetectorTest, CapsAsOpenCvDoes) {
  const cv::Mat gray = TourGrays()[0];
  SiftParameters p;
  p.max_features = 200;
  const Agreement a = CompareWithOpenCv(gray, p);
  Print("cap 200", a);
  EXPECT_GE(a.ours, 200u);
  EXPECT_LE(a.ours, 202u);
  EXPECT_GT(a.close, 0.98);
}

// Other thresholds reach the same stages: fewer keypoints at a higher contrast threshold,
// as OpenCV finds.
TEST(SiftDetectorTest, ThresholdsAsOpenCvReadsThem) {
  const cv::Mat gray = TourGrays()[0];
  SiftParameters p;
  p.contrast_threshold = 0.08;
  p.edge_threshold = 5;
  p.sigma = 2.0;
  const Agreement a = CompareWithOpenCv(gray, p);
  Print("contrast 0.08, edge 5, sigma 2", a);
  EXPECT_GT(a.close, 0.98);
  EXPECT_LT(a.theirs, CompareWithOpenCv(gray, SiftParameters{}).theirs);
}

// On the pool every stage runs in strips: the same keypoints and descriptors, bit for bit,
// as on one thread.
TEST(SiftDetectorTest, OnThePoolAsOnOneThread) {
  const cv::Mat gray = TourGrays()[0];
  std::vector<cv::KeyPoint> serial;
  cv::Mat serial_d;
  DetectAndDescribeSift(gray, SiftParameters{}, &serial, &serial_d);
  ThreadPool pool(2);
  OpenCvOnThreadPool routed(&pool);
  for (int run = 0; run < 3; ++run) {
    std::vector<cv::KeyPoint> pooled;
    cv::Mat pooled_d;
    DetectAndDescribeSift(gray, SiftParameters{}, &pooled, &pooled_d);
    ASSERT_EQ(pooled.size(), serial.size()) << run;
    for (size_t i = 0; i < serial.size(); ++i) {
      ASSERT_EQ(pooled[i].pt, serial[i].pt) << i;
      ASSERT_EQ(pooled[i].angle, serial[i].angle) << i;
      ASSERT_EQ(pooled[i].size, serial[i].size) << i;
    }
    EXPECT_EQ(cv::norm(serial_d, pooled_d, cv::NORM_INF), 0) << run;
  }
}

// A blank frame has no keypoints; a tiny one (fewer rows than the border) none either, and
// neither is an error.
TEST(SiftDetectorTest, BlankAndTinyFrames) {
  for (const cv::Size size : {cv::Size(480, 270), cv::Size(16, 16), cv::Size(9, 40)}) {
    std::vector<cv::KeyPoint> k;
    cv::Mat d;
    DetectAndDescribeSift(cv::Mat(size, CV_8U, cv::Scalar(90)), SiftParameters{}, &k, &d);
    EXPECT_TRUE(k.empty()) << size;
    EXPECT_EQ(d.rows, 0) << size;
    EXPECT_EQ(d.cols, 128) << size;
  }
}

}  // namespace
}  // namespace sceneloc
