#include "common/training/tracker.h"

#include <algorithm>
#include <opencv2/calib3d.hpp>

namespace sceneloc {
namespace {

using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Nearest feature of `b` for each feature of `a` within distance t, made one-to-one: when
// several features of `a` pick the same feature of `b`, only the closest keeps it.
std::vector<int> NearestWithin(const FeatureSet& a, const FeatureSet& b, float t) {
  const RowMatrix dots = a.local * b.local.transpose();
  const Eigen::VectorXf b_sqnorm = b.local.rowwise().squaredNorm();
  std::vector<int> next(static_cast<size_t>(a.size()), -1);
  std::vector<float> best_d2(static_cast<size_t>(b.size()), t * t);
  std::vector<int> owner(static_cast<size_t>(b.size()), -1);
  for (int i = 0; i < a.size(); ++i) {
    const float a2 = a.local.row(i).squaredNorm();
    int best = -1;
    float best_i = t * t;
    for (int j = 0; j < b.size(); ++j) {
      const float d2 = a2 + b_sqnorm[j] - 2.0f * dots(i, j);
      if (d2 < best_i) {
        best_i = d2;
        best = j;
      }
    }
    if (best < 0 || best_i >= best_d2[static_cast<size_t>(best)]) continue;
    if (owner[static_cast<size_t>(best)] >= 0) next[static_cast<size_t>(owner[best])] = -1;
    owner[static_cast<size_t>(best)] = i;
    best_d2[static_cast<size_t>(best)] = best_i;
    next[static_cast<size_t>(i)] = best;
  }
  return next;
}

}  // namespace

std::vector<int> LinkImagePair(const FeatureSet& a, const FeatureSet& b,
                               const TrainOptions& options, TrackingStats* stats) {
  const std::vector<int> candidate =
      NearestWithin(a, b, static_cast<float>(options.track_distance_threshold));
  std::vector<int> from;
  std::vector<cv::Point2f> pa, pb;
  for (int i = 0; i < a.size(); ++i) {
    const int j = candidate[static_cast<size_t>(i)];
    if (j < 0) continue;
    const Keypoint& ka = a.keypoints[static_cast<size_t>(i)];
    const Keypoint& kb = b.keypoints[static_cast<size_t>(j)];
    from.push_back(i);
    pa.emplace_back(ka.x, ka.y);
    pb.emplace_back(kb.x, kb.y);
  }
  stats->candidate_links += from.size();
  std::vector<int> next(candidate.size(), -1);
  if (static_cast<int>(from.size()) < options.min_links_per_pair) {
    ++stats->pairs_unverified;
    return next;
  }
  cv::Mat inliers;
  const double threshold_px = options.ransac_threshold * std::max(a.image_width, a.image_height);
  const cv::Mat f = cv::findFundamentalMat(pa, pb, cv::FM_RANSAC, threshold_px,
                                           options.ransac_confidence, inliers);
  if (f.empty() || inliers.empty()) {
    ++stats->pairs_unverified;
    return next;
  }
  for (size_t k = 0; k < from.size(); ++k) {
    if (inliers.at<uchar>(static_cast<int>(k)) == 0) continue;
    next[static_cast<size_t>(from[k])] = candidate[static_cast<size_t>(from[k])];
    ++stats->verified_links;
  }
  return next;
}

std::vector<Track> BuildTracks(const std::vector<FeatureSet>& tour, const TrainOptions& options,
                               ThreadPool* pool, TrackingStats* stats) {
  const size_t num_pairs = tour.size() < 2 ? 0 : tour.size() - 1;
  std::vector<std::vector<int>> links(num_pairs);
  std::vector<TrackingStats> pair_stats(num_pairs);
  auto link = [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      links[i] = LinkImagePair(tour[i], tour[i + 1], options, &pair_stats[i]);
    }
  };
  if (pool != nullptr) {
    pool->ParallelFor(num_pairs, 1, link);
  } else {
    link(0, num_pairs);
  }
  for (const auto& s : pair_stats) {
    stats->candidate_links += s.candidate_links;
    stats->verified_links += s.verified_links;
    stats->pairs_unverified += s.pairs_unverified;
  }
  TourLinks tour_links;
  tour_links.next = std::move(links);
  for (const FeatureSet& f : tour) tour_links.feature_counts.push_back(f.size());
  return ChainTracks(tour_links);
}

std::vector<Track> ChainTracks(const TourLinks& links) {
  const size_t num_pairs = links.next.size();
  // A track starts at a feature that no link reaches and follows the links forward.
  std::vector<Track> tracks;
  for (size_t image = 0; image < num_pairs; ++image) {
    std::vector<bool> reached(static_cast<size_t>(links.feature_counts[image]), false);
    if (image > 0) {
      for (int target : links.next[image - 1]) {
        if (target >= 0) reached[static_cast<size_t>(target)] = true;
      }
    }
    for (int f = 0; f < links.feature_counts[image]; ++f) {
      if (reached[static_cast<size_t>(f)] || links.next[image][static_cast<size_t>(f)] < 0) {
        continue;
      }
      Track track;
      size_t i = image;
      int feature = f;
      while (feature >= 0) {
        track.push_back({static_cast<uint32_t>(i), static_cast<uint32_t>(feature)});
        feature = i < num_pairs ? links.next[i][static_cast<size_t>(feature)] : -1;
        ++i;
      }
      tracks.push_back(std::move(track));
    }
  }
  return tracks;
}

}  // namespace sceneloc
