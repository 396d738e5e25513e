// Shared by the SIFT tests: grey frames of the generated tour and the cosine of two
// descriptors.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "common/synthetic/tour_generator.h"

namespace sceneloc {

// The first `sizes.size()` frames of the generated tour in grey, frame i resized to
// sizes[i] (480x270 is the extractor's working frame for the tour's 960x540).
inline std::vector<cv::Mat> TourGrayFrames(const std::vector<cv::Size>& sizes) {
  TourOptions tour;
  tour.num_locations = static_cast<int>(sizes.size());
  auto jpegs = RenderTourJpegs(tour, kTrainingPass);
  EXPECT_TRUE(jpegs.ok());
  std::vector<cv::Mat> out;
  for (size_t i = 0; jpegs.ok() && i < sizes.size(); ++i) {
    const std::string& jpeg = (*jpegs)[i];
    const cv::Mat image =
        cv::imdecode(std::vector<uchar>(jpeg.begin(), jpeg.end()), cv::IMREAD_GRAYSCALE);
    cv::Mat gray;
    cv::resize(image, gray, sizes[i], 0, 0, cv::INTER_AREA);
    out.push_back(gray);
  }
  return out;
}

// The cosine of two 128-value descriptors (0 if either is zero).
inline double DescriptorCosine(const float* a, const float* b) {
  double ab = 0, aa = 0, bb = 0;
  for (int i = 0; i < 128; ++i) {
    ab += a[i] * b[i];
    aa += a[i] * a[i];
    bb += b[i] * b[i];
  }
  return aa > 0 && bb > 0 ? ab / std::sqrt(aa * bb) : 0;
}

}  // namespace sceneloc
