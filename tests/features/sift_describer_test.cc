#include "common/features/sift_describer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "common/features/opencv_threads.h"
#include "common/util/thread_pool.h"
#include "sift_test_frames.h"

namespace sceneloc {
namespace {

// A 480x270 grey frame of the generated tour (what the extractor works on).
cv::Mat TourGray() { return TourGrayFrames({cv::Size(480, 270)})[0]; }

// SIFT's keypoints of the frame at octave 0 and above, on their own layers, and the same at
// twice the size on layer 0 one octave up (the extractor's context keypoints).
std::vector<cv::KeyPoint> Keypoints(const cv::Mat& gray, int layers) {
  std::vector<cv::KeyPoint> detected;
  cv::SIFT::create(0, layers)->detect(gray, detected);
  std::vector<cv::KeyPoint> out;
  for (const cv::KeyPoint& k : detected) {
    const int octave = static_cast<int8_t>(k.octave & 0xff);
    if (octave >= 0) out.push_back(k);
    cv::KeyPoint wide = k;
    wide.size *= 2;
    wide.octave = (k.octave & ~0xffff) | ((octave + 1) & 0xff);
    if (octave + 1 <= 3) out.push_back(wide);
  }
  return out;
}

struct Agreement {
  double mean = 0;
  double share_close = 0;  // of descriptors with cosine above 0.98
  double share_equal = 0;  // of descriptors equal in every value
};

Agreement CompareWithOpenCv(const cv::Mat& gray, const std::vector<cv::KeyPoint>& keypoints,
                            int layers) {
  const cv::Mat ours = DescribeSiftKeypoints(gray, keypoints, layers, 1.6);
  std::vector<cv::KeyPoint> theirs_keypoints = keypoints;
  cv::Mat theirs;
  cv::SIFT::create(0, layers)->compute(gray, theirs_keypoints, theirs);
  EXPECT_EQ(ours.rows, static_cast<int>(keypoints.size()));
  EXPECT_EQ(theirs.rows, ours.rows);
  Agreement a;
  for (int i = 0; i < ours.rows; ++i) {
    const double c = DescriptorCosine(ours.ptr<float>(i), theirs.ptr<float>(i));
    a.mean += c;
    a.share_close += c > 0.98;
    a.share_equal += cv::norm(ours.row(i), theirs.row(i), cv::NORM_INF) == 0;
  }
  a.mean /= ours.rows;
  a.share_close /= ours.rows;
  a.share_equal /= ours.rows;
  return a;
}

// The descriptor is SIFT's: on every keypoint of a frame, at every octave and layer SIFT
// uses, ours and OpenCV's agree up to the rounding of the blur (one Gaussian per image
// here, a chain of them in SIFT). A lost rotation, a wrong scale or octave, a misplaced
// histogram cell drops the agreement far below these figures (ContextIsNotTheLocal...).
TEST(SiftDescriberTest, AgreesWithOpenCvSift) {
  const cv::Mat gray = TourGray();
  for (const int layers : {3, 5}) {
    const std::vector<cv::KeyPoint> keypoints = Keypoints(gray, layers);
    ASSERT_GT(keypoints.size(), 300u);
    const Agreement a = CompareWithOpenCv(gray, keypoints, layers);
    std::printf("%d layers: %zu keypoints, mean cosine %.6f, above 0.98 %.4f, equal %.4f\n", layers,
                keypoints.size(), a.mean, a.share_close, a.share_equal);
    EXPECT_GT(a.mean, 0.995) << layers << " layers";
    EXPECT_GT(a.share_close, 0.97) << layers << " layers";
  }
}

// Windows that leave the image, windows larger than it (the radius is clipped to the
// image's diagonal), every octave and angle: still SIFT's descriptor.
TEST(SiftDescriberTest, WindowsAtTheBorderAndLargerThanTheImage) {
  const cv::Mat gray = TourGray();
  std::vector<cv::KeyPoint> keypoints;
  for (const cv::Point2f p :
       {cv::Point2f(0, 0), cv::Point2f(479, 269), cv::Point2f(3.4f, 200), cv::Point2f(240, 135)}) {
    for (const float size : {6.f, 40.f, 900.f}) {
      for (const float angle : {0.f, 45.f, 359.99f}) {
        for (int octave = 0; octave <= 3; ++octave) {
          keypoints.emplace_back(p, size * static_cast<float>(1 << octave), angle, 0.f,
                                 ((octave % 3) << 8) | octave);
        }
      }
    }
  }
  const cv::Mat ours = DescribeSiftKeypoints(gray, keypoints, 3, 1.6);
  cv::Mat theirs;
  cv::SIFT::create()->compute(gray, keypoints, theirs);
  ASSERT_EQ(theirs.rows, ours.rows);
  for (int i = 0; i < ours.rows; ++i) {
    EXPECT_GT(DescriptorCosine(ours.ptr<float>(i), theirs.ptr<float>(i)), 0.999)
        << keypoints[static_cast<size_t>(i)].pt << " size "
        << keypoints[static_cast<size_t>(i)].size << " octave " << i % 4;
  }
}

// Every sub-pixel position, size and angle writes inside the histogram: a sample just inside
// the last cell whose shifted coordinate rounds up to the cell past it once wrote beyond
// the histogram (caught by the sanitizer build's run of this test). Values stay SIFT's.
TEST(SiftDescriberTest, EveryPlacementStaysInsideTheHistogram) {
  const cv::Mat gray = TourGray();
  std::vector<cv::KeyPoint> keypoints;
  for (int i = 0; i < 2000; ++i) {
    const float x = 20.f + static_cast<float>(i % 97) * 4.4321f;
    const float y = 20.f + static_cast<float>(i % 53) * 4.1234f;
    const float size = 2.f + static_cast<float>(i % 37) * 0.7371f;
    const float angle = std::fmod(static_cast<float>(i) * 7.919f, 360.f);
    keypoints.emplace_back(cv::Point2f(x, y), size, angle, 0.f, ((1 + i % 3) << 8) | 0);
  }
  const cv::Mat ours = DescribeSiftKeypoints(gray, keypoints, 3, 1.6);
  cv::Mat theirs;
  cv::SIFT::create()->compute(gray, keypoints, theirs);
  ASSERT_EQ(theirs.rows, ours.rows);
  double lowest = 1;
  for (int i = 0; i < ours.rows; ++i) {
    lowest = std::min(lowest, DescriptorCosine(ours.ptr<float>(i), theirs.ptr<float>(i)));
  }
  EXPECT_GT(lowest, 0.999);
}

TEST(SiftDescriberTest, NoKeypointsNoRows) {
  const cv::Mat d = DescribeSiftKeypoints(TourGray(), {}, 3, 1.6);
  EXPECT_EQ(d.rows, 0);
  EXPECT_EQ(d.cols, 128);
}

// The doubled base (octave -1) is SIFT's own pyramid's; asking for it here is a caller's
// mistake, caught, not read out of bounds.
TEST(SiftDescriberTest, RefusesTheDoubledBase) {
  const std::vector<cv::KeyPoint> below{cv::KeyPoint(10, 10, 4, 0, 0, 0xff | (1 << 8))};
  EXPECT_THROW(DescribeSiftKeypoints(TourGray(), below, 3, 1.6), cv::Exception);
}

// Keypoints are described in parallel on the pool's idle threads (opencv_threads.h): the
// same values as on one thread, every row where it belongs.
TEST(SiftDescriberTest, OnThePoolAsOnOneThread) {
  const cv::Mat gray = TourGray();
  const std::vector<cv::KeyPoint> keypoints = Keypoints(gray, 3);
  const cv::Mat serial = DescribeSiftKeypoints(gray, keypoints, 3, 1.6);
  ThreadPool pool(2);
  OpenCvOnThreadPool routed(&pool);
  for (int run = 0; run < 3; ++run) {
    const cv::Mat pooled = DescribeSiftKeypoints(gray, keypoints, 3, 1.6);
    EXPECT_EQ(cv::norm(serial, pooled, cv::NORM_INF), 0) << run;
  }
}

}  // namespace
}  // namespace sceneloc
