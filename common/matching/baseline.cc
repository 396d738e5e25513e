#include "common/matching/baseline.h"

#include <cstdlib>
#include <opencv2/flann.hpp>

namespace sceneloc {
namespace {

class FlannVotingBaseline final : public VotingBaseline {
 public:
  FlannVotingBaseline(cv::Mat descriptors, std::vector<int> image_of, int num_images,
                      const BaselineOptions& options)
      : descriptors_(std::move(descriptors)),
        image_of_(std::move(image_of)),
        num_images_(num_images),
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
    return result;
  }

 private:
  const cv::Mat descriptors_;  // the index keeps pointers into this
  const std::vector<int> image_of_;
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
  std::vector<int> image_of;
  image_of.reserve(static_cast<size_t>(total));
  int row = 0;
  for (size_t l = 0; l < tour.size(); ++l) {
    for (int i = 0; i < tour[l].size(); ++i, ++row) {
      std::copy(tour[l].local.row(i).data(), tour[l].local.row(i).data() + kDescriptorSize,
                descriptors.ptr<float>(row));
      image_of.push_back(static_cast<int>(l));
    }
  }
  try {
    // FLANN's randomised kd-trees draw from rand() and OpenCV's RNG; fixed seeds make the
    // baseline's figures repeatable from run to run.
    std::srand(0);
    cv::theRNG().state = 0x12345678;
    return std::unique_ptr<VotingBaseline>(std::make_unique<FlannVotingBaseline>(
        std::move(descriptors), std::move(image_of), static_cast<int>(tour.size()), options));
  } catch (const cv::Exception& e) {
    return Internal(std::string("building the FLANN index failed: ") + e.what());
  }
}

}  // namespace sceneloc
