#include "common/matching/evidence.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace sceneloc {
namespace {

float Median(std::vector<float> values) {
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

}  // namespace

std::vector<float> RobustZ(const std::vector<float>& distance) {
  if (distance.empty()) return {};
  const float median = Median(distance);
  std::vector<float> deviation(distance.size());
  for (size_t i = 0; i < distance.size(); ++i) deviation[i] = std::abs(distance[i] - median);
  const float spread = std::max(1e-6f, 1.4826f * Median(deviation));
  std::vector<float> z(distance.size());
  for (size_t i = 0; i < distance.size(); ++i) z[i] = (median - distance[i]) / spread;
  return z;
}

std::vector<CandidateEvidence> SelectCandidates(const std::vector<int>& by_likelihood,
                                                const std::vector<float>& likelihood,
                                                const std::vector<float>& holistic,
                                                const std::vector<float>& holistic_z,
                                                const MatchOptions& options) {
  std::vector<int> by_holistic(holistic.size()), holistic_rank(likelihood.size(), -1);
  std::iota(by_holistic.begin(), by_holistic.end(), 0);
  std::stable_sort(by_holistic.begin(), by_holistic.end(),
                   [&](int a, int b) { return holistic[a] < holistic[b]; });
  for (size_t r = 0; r < by_holistic.size(); ++r) holistic_rank[by_holistic[r]] = int(r);
  std::vector<CandidateEvidence> out;
  std::vector<bool> taken(likelihood.size(), false);
  const auto add = [&](int l) {
    if (taken[l]) return;
    taken[l] = true;
    CandidateEvidence c;
    c.location = l;
    c.likelihood = likelihood[l];
    if (!holistic.empty()) {
      c.holistic = holistic[l];
      c.holistic_rank = holistic_rank[l];
      c.holistic_z = holistic_z[l];
    }
    out.push_back(c);
  };
  const size_t top_l = std::min(by_likelihood.size(), static_cast<size_t>(options.verify_top));
  for (size_t i = 0; i < top_l; ++i) add(by_likelihood[i]);
  const size_t top_h = std::min(by_holistic.size(), static_cast<size_t>(options.holistic_top));
  for (size_t i = 0; i < top_h; ++i) add(by_holistic[i]);
  return out;
}

double VerifiedScore(const CandidateEvidence& c, const MatchOptions& options) {
  double verified = c.inliers;
  if (options.verify_scale_sigma > 0) {
    const double s = options.verify_scale_sigma;
    const double m = c.log_scale - options.camera_log_scale;
    verified *= std::exp(-m * m / (2 * s * s));
  }
  return verified;
}

// Where local features fail (night, blur) the holistic evidence decides; where they work, a
// clear geometric match overrides a look-alike. Inliers up to the chance level say nothing.
double FuseEvidence(const CandidateEvidence& c, const MatchOptions& options) {
  const double verified = VerifiedScore(c, options);
  if (!options.use_holistic || c.holistic < 0) return verified;
  return c.holistic_z +
         options.verify_weight * std::max(0.0, verified - options.verify_chance_inliers);
}

std::vector<float> LocationScores(const std::vector<CandidateEvidence>& candidates,
                                  const std::vector<float>& holistic_z, size_t num_locations,
                                  const MatchOptions& options) {
  std::vector<float> scores = holistic_z;
  scores.resize(num_locations, 0.0f);
  if (!options.use_holistic) std::fill(scores.begin(), scores.end(), 0.0f);
  ScoreCandidates(candidates, options, &scores);
  return scores;
}

void ScoreCandidates(const std::vector<CandidateEvidence>& candidates, const MatchOptions& options,
                     std::vector<float>* scores) {
  for (const CandidateEvidence& c : candidates) {
    if (c.location < 0 || static_cast<size_t>(c.location) >= scores->size()) continue;
    const double excess = std::max(0.0, VerifiedScore(c, options) - options.verify_chance_inliers);
    const bool holistic = options.use_holistic && c.holistic >= 0;
    (*scores)[c.location] =
        static_cast<float>((holistic ? c.holistic_z : 0.0) + options.verify_weight * excess);
  }
}

}  // namespace sceneloc
