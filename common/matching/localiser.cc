#include "common/matching/localiser.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "common/matching/descriptor_similarity.h"
#include "common/matching/neighbourhood.h"
#include "common/matching/verification.h"
#include "common/util/timer.h"

namespace sceneloc {

Status MatchOptions::Validate() const {
  if (!(s_min > 0.0 && s_min <= 1.0)) return InvalidArgument("s_min must be in (0, 1]");
  if (max_neighbours < 0) return InvalidArgument("max_neighbours must be >= 0 (0 = all)");
  if (top_k < 1 || top_k > 1000) return InvalidArgument("top_k must be in [1, 1000]");
  if (verify_top < 0 || verify_top > 1000)
    return InvalidArgument("verify_top must be in [0, 1000]");
  if (!(verify_ransac_px > 0.0)) return InvalidArgument("verify_ransac_px must be > 0");
  if (verify_ransac_iterations < 1) return InvalidArgument("verify_ransac_iterations must be >= 1");
  if (!(verify_scale_sigma >= 0.0)) return InvalidArgument("verify_scale_sigma must be >= 0");
  if (!(size_exponent >= 0.0 && size_exponent <= 2.0)) {
    return InvalidArgument("size_exponent must be in [0, 2]");
  }
  return Status::Ok();
}

Status ValidateFeatureSet(const FeatureSet& f) {
  if (f.image_width <= 0 || f.image_height <= 0) {
    return InvalidArgument("feature set image size must be positive");
  }
  const auto n = static_cast<Eigen::Index>(f.keypoints.size());
  if (f.local.rows() != n || f.context.rows() != n) {
    return InvalidArgument("feature set has " + std::to_string(n) + " keypoints but " +
                           std::to_string(f.local.rows()) + " local and " +
                           std::to_string(f.context.rows()) + " context descriptors");
  }
  if (!f.local.allFinite() || !f.context.allFinite()) {
    return InvalidArgument("feature set descriptors hold a non-finite number");
  }
  for (size_t i = 0; i < f.keypoints.size(); ++i) {
    const Keypoint& k = f.keypoints[i];
    if (!std::isfinite(k.x) || !std::isfinite(k.y) || !std::isfinite(k.size) ||
        !std::isfinite(k.angle)) {
      return InvalidArgument("keypoint " + std::to_string(i) + " holds a non-finite number");
    }
  }
  return Status::Ok();
}

StatusOr<FrameScores> ScoreLocations(const FeatureSet& features, const Map& map,
                                     const MatchOptions& options, ThreadPool* pool,
                                     LocaliseResult* stats) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  SCENELOC_RETURN_IF_ERROR(ValidateFeatureSet(features));
  Stopwatch watch;
  const std::vector<DescriptorMatch> matches =
      ComputeDescriptorMatches(features, map, static_cast<float>(options.s_min), pool);
  stats->descriptor_matches = matches.size();
  stats->timings.descriptor_ms = watch.Milliseconds();

  watch.Reset();
  std::vector<float> neighbourhood;
  if (options.use_neighbourhood) {
    neighbourhood = NeighbourhoodSimilarities(features, map, matches, options.include_centre_term,
                                              options.max_neighbours, pool);
  }
  stats->timings.neighbourhood_ms = watch.Milliseconds();

  watch.Reset();
  // Each feature's total similarity mass, the denominator of p(g|f).
  std::vector<float> mass;
  if (options.distinctiveness) {
    mass.assign(static_cast<size_t>(features.size()), 0.0f);
    for (const DescriptorMatch& m : matches) mass[m.feature] += m.similarity;
  }
  // max_f S(f, g) per landmark, then eq. 3.
  FrameScores scores;
  std::vector<float>& best = scores.best_score;
  best.assign(static_cast<size_t>(map.num_landmarks()), 0.0f);
  scores.best_feature.assign(best.size(), -1);
  for (size_t k = 0; k < matches.size(); ++k) {
    const DescriptorMatch& m = matches[k];
    float s = m.similarity * (options.use_neighbourhood ? neighbourhood[k] : 1.0f);
    if (options.distinctiveness) s *= m.similarity / mass[m.feature];
    if (s > best[m.landmark]) {
      best[m.landmark] = s;
      scores.best_feature[m.landmark] = static_cast<int32_t>(m.feature);
    }
  }
  std::vector<float>& likelihood = scores.likelihood;
  likelihood.assign(static_cast<size_t>(map.num_images()), 0.0f);
  for (int l = 0; l < map.num_images(); ++l) {
    const uint32_t begin = map.image_offsets[l], end = map.image_offsets[l + 1];
    if (begin == end) continue;
    double sum = 0;
    for (uint32_t k = begin; k < end; ++k) sum += best[map.image_landmarks[k]];
    likelihood[static_cast<size_t>(l)] =
        static_cast<float>(sum / std::pow(static_cast<double>(end - begin), options.size_exponent));
  }
  stats->timings.likelihood_ms = watch.Milliseconds();
  return scores;
}

namespace {

// Locations by descending L (lowest index first on ties).
std::vector<int> RankByLikelihood(const std::vector<float>& likelihood) {
  std::vector<int> order(likelihood.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return likelihood[a] > likelihood[b]; });
  return order;
}

float Ratio(double first, double second) {
  return first + second > 0 ? static_cast<float>(first / (first + second)) : 0.0f;
}

// What verification found for each location (-1 inliers: not verified).
struct Evidence {
  std::vector<int> inliers;
  std::vector<float> log_scale;
  std::vector<double> score;  // inliers, weighted by scale agreement
};

// Verifies the first options.verify_top locations of `order` and re-sorts them by their
// verified score (stable, so L breaks ties).
Evidence VerifyAndRerank(const FeatureSet& features, const Map& map, const FrameScores& scores,
                         const MatchOptions& options, ThreadPool* pool, std::vector<int>* order) {
  const size_t n = scores.likelihood.size();
  Evidence e{std::vector<int>(n, -1), std::vector<float>(n, 0.0f), std::vector<double>(n, 0.0)};
  const size_t verified = std::min(order->size(), static_cast<size_t>(options.verify_top));
  if (verified == 0) return e;
  // One task per candidate; each RANSAC is independent.
  auto verify = [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const int l = (*order)[i];
      const Verification v =
          VerifyCandidate(features, map, l, scores.best_score, scores.best_feature,
                          options.verify_ransac_px, options.verify_ransac_iterations);
      e.inliers[l] = v.inliers;
      e.log_scale[l] = v.log_scale;
      e.score[l] = v.inliers;
      if (options.verify_scale_sigma > 0) {
        const double s = options.verify_scale_sigma;
        e.score[l] *= std::exp(-v.log_scale * v.log_scale / (2 * s * s));
      }
    }
  };
  if (pool != nullptr) {
    pool->ParallelFor(verified, 1, verify);
  } else {
    verify(0, verified);
  }
  std::stable_sort(order->begin(), order->begin() + static_cast<std::ptrdiff_t>(verified),
                   [&](int a, int b) { return e.score[a] > e.score[b]; });
  return e;
}

}  // namespace

StatusOr<LocaliseResult> Localise(const FeatureSet& features, const Map& map,
                                  const MatchOptions& options, ThreadPool* pool) {
  Stopwatch total;
  LocaliseResult result;
  SCENELOC_ASSIGN_OR_RETURN(const FrameScores scores,
                            ScoreLocations(features, map, options, pool, &result));
  const std::vector<float>& likelihood = scores.likelihood;
  Stopwatch stage;
  std::vector<int> order = RankByLikelihood(likelihood);
  result.timings.likelihood_ms += stage.Milliseconds();

  stage.Reset();
  const Evidence evidence = VerifyAndRerank(features, map, scores, options, pool, &order);
  result.timings.verify_ms = stage.Milliseconds();

  const size_t k = std::min(order.size(), static_cast<size_t>(options.top_k));
  for (size_t i = 0; i < k; ++i) {
    const int l = order[i];
    result.ranked.push_back(
        {l, map.image_names[l], likelihood[l], evidence.inliers[l], evidence.log_scale[l]});
  }
  if (order.size() >= 2) {
    // Verified scores decide when the best candidate has any geometric support; with none
    // (e.g. too few correspondences), the ranking and its confidence are L's.
    const double s1 = evidence.score[order[0]], s2 = evidence.score[order[1]];
    result.confidence = s1 > 0 ? Ratio(s1, s2) : Ratio(likelihood[order[0]], likelihood[order[1]]);
  } else if (!order.empty() && likelihood[order[0]] > 0) {
    result.confidence = 1.0f;
  }
  result.timings.total_ms = total.Milliseconds();
  return result;
}

}  // namespace sceneloc
