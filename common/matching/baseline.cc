#include "common/matching/baseline.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/flann.hpp>

namespace sceneloc {
namespace {

class FlannVotingBaseline final : public VotingBaseline {
 public:
  FlannVotingBaseline(cv::Mat descriptors, std::vector<int> image_of, std::vector<int> offsets,
                      std::vector<cv::Point2f> points, const BaselineOptions& options)
      : descriptors_(std::move(descriptors)),
        image_of_(std::move(image_of)),
        offsets_(std::move(offsets)),
        points_(std::move(points)),
        num_images_(static_cast<int>(offsets_.size()) - 1),
        options_(options),
        index_(descriptors_, cv::flann::KDTreeIndexParams(options.trees)) {}

  BaselineResult Localise(const FeatureSet& query) override {
    BaselineResult result;
    result.votes.assign(static_cast<size_t>(num_images_), 0);
    if (query.size() == 0) return result;
    const cv::Mat q(query.size(), kDescriptorSize, CV_32F, const_cast<float*>(query.local.data()));
    cv::Mat indices, dists;
    index_.knnSearch(q, indices, dists, 2, cv::flann::SearchParams(options_.checks));
    const float ratio2 = static_cast<float>(options_.ratio * options_.ratio);
    for (int i = 0; i < q.rows; ++i) {
      const int nearest = indices.at<int>(i, 0);
      // FLANN's L2 returns squared distances.
      if (nearest < 0 || dists.at<float>(i, 0) >= ratio2 * dists.at<float>(i, 1)) continue;
      ++result.votes[static_cast<size_t>(image_of_[static_cast<size_t>(nearest)])];
    }
    int v1 = 0, v2 = 0;
    for (int l = 0; l < num_images_; ++l) {
      const int v = result.votes[static_cast<size_t>(l)];
      if (v > v1) {
        v2 = v1;
        v1 = v;
        result.best = l;
      } else if (v > v2) {
        v2 = v;
      }
    }
    result.confidence = v1 + v2 > 0 ? static_cast<float>(v1) / static_cast<float>(v1 + v2) : 0.0f;
    if (options_.rerank_top > 0 && result.best >= 0) {
      const auto start = std::chrono::steady_clock::now();
      Rerank(query, q, &result);
      result.rerank_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
    }
    return result;
  }

 private:
  // Inliers of a fundamental matrix among the ratio-test matches of the query to image l.
  int Inliers(const FeatureSet& query, const cv::Mat& q, int l) const {
    const cv::Mat tour = descriptors_.rowRange(offsets_[l], offsets_[l + 1]);
    if (tour.rows < 2) return 0;
    std::vector<std::vector<cv::DMatch>> knn;
    cv::BFMatcher(cv::NORM_L2).knnMatch(q, tour, knn, 2);
    std::vector<cv::Point2f> a, b;
    for (const auto& m : knn) {
      if (m.size() < 2 || m[0].distance >= options_.ratio * m[1].distance) continue;
      const Keypoint& k = query.keypoints[static_cast<size_t>(m[0].queryIdx)];
      a.emplace_back(k.x, k.y);
      b.push_back(points_[static_cast<size_t>(offsets_[l] + m[0].trainIdx)]);
    }
    if (a.size() < 8) return 0;
    cv::Mat inliers;
    cv::theRNG().state = 0x12345678;
    const cv::Mat f =
        cv::findFundamentalMat(a, b, cv::FM_RANSAC, options_.ransac_threshold_px, 0.99, inliers);
    return f.empty() || inliers.empty() ? 0 : cv::countNonZero(inliers);
  }

  void Rerank(const FeatureSet& query, const cv::Mat& q, BaselineResult* result) const {
    std::vector<int> order(static_cast<size_t>(num_images_));
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return result->votes[a] > result->votes[b]; });
    order.resize(std::min(order.size(), static_cast<size_t>(options_.rerank_top)));
    int i1 = -1, i2 = 0;
    for (int l : order) {
      const int n = Inliers(query, q, l);
      if (n > i1) {
        i2 = std::max(i2, i1);
        i1 = n;
        result->reranked_best = l;
      } else {
        i2 = std::max(i2, n);
      }
    }
    result->reranked_inliers = i1;
    result->reranked_confidence = i1 + i2 > 0 ? static_cast<float>(i1) / (i1 + i2) : 0.0f;
  }

  const cv::Mat descriptors_;  // the index keeps pointers into this
  const std::vector<int> image_of_;
  const std::vector<int> offsets_;         // rows of image l: [offsets_[l], offsets_[l + 1])
  const std::vector<cv::Point2f> points_;  // keypoint position of each row
  const int num_images_;
  const BaselineOptions options_;
  cv::flann::Index index_;
};

}  // namespace

StatusOr<std::unique_ptr<VotingBaseline>> VotingBaseline::Build(const std::vector<FeatureSet>& tour,
                                                                const BaselineOptions& options) {
  int total = 0;
  for (const FeatureSet& f : tour) total += f.size();
  if (total == 0) return FailedPrecondition("the baseline's tour has no feature");
  cv::Mat descriptors(total, kDescriptorSize, CV_32F);
  std::vector<int> image_of, offsets{0};
  std::vector<cv::Point2f> points;
  image_of.reserve(static_cast<size_t>(total));
  int row = 0;
  for (size_t l = 0; l < tour.size(); ++l) {
    for (int i = 0; i < tour[l].size(); ++i, ++row) {
      std::copy(tour[l].local.row(i).data(), tour[l].local.row(i).data() + kDescriptorSize,
                descriptors.ptr<float>(row));
      image_of.push_back(static_cast<int>(l));
      points.emplace_back(tour[l].keypoints[static_cast<size_t>(i)].x,
                          tour[l].keypoints[static_cast<size_t>(i)].y);
    }
    offsets.push_back(row);
  }
  try {
    // FLANN's randomised kd-trees draw from rand() and OpenCV's RNG; fixed seeds make the
    // baseline's figures repeatable from run to run.
    std::srand(0);
    cv::theRNG().state = 0x12345678;
    return std::unique_ptr<VotingBaseline>(
        std::make_unique<FlannVotingBaseline>(std::move(descriptors), std::move(image_of),
                                              std::move(offsets), std::move(points), options));
  } catch (const cv::Exception& e) {
    return Internal(std::string("building the FLANN index failed: ") + e.what());
  }
}

}  // namespace sceneloc
