#include "common/matching/evidence.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace sceneloc {
namespace {

float Median(std::vector<float> values) {
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

// VerifiedScore with the camera's log scale `camera`.
double VerifiedScoreFor(const CandidateEvidence& c, const MatchOptions& options, double camera) {
  double verified = c.inliers;
  if (options.verify_scale_sigma > 0) {
    const double s = options.verify_scale_sigma;
    const double m = c.log_scale - camera;
    verified *= std::exp(-m * m / (2 * s * s));
  }
  return verified;
}

// A candidate's entry of LocationScores with the camera's log scale `camera`.
double CandidateScore(const CandidateEvidence& c, const MatchOptions& options, double camera) {
  const double excess =
      std::max(0.0, VerifiedScoreFor(c, options, camera) - options.verify_chance_inliers);
  const bool holistic = options.use_holistic && c.holistic >= 0;
  return (holistic ? c.holistic_z : 0.0) + options.verify_weight * excess;
}

}  // namespace

std::vector<float> RobustZ(const std::vector<float>& distance) {
  return RobustZ(distance, distance);
}

std::vector<float> RobustZ(const std::vector<float>& distance,
                           const std::vector<float>& reference) {
  if (distance.empty() || reference.empty()) return {};
  const float median = Median(reference);
  std::vector<float> deviation(reference.size());
  for (size_t i = 0; i < reference.size(); ++i) deviation[i] = std::abs(reference[i] - median);
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
  return VerifiedScoreFor(c, options, options.camera_log_scale);
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
    (*scores)[c.location] =
        static_cast<float>(CandidateScore(c, options, options.camera_log_scale));
  }
}

double CameraAveragedPosterior(const std::vector<float>& location_scores,
                               const std::vector<CandidateEvidence>& candidates, int answer,
                               int tolerance, double temperature, const MatchOptions& options,
                               const LocationTemperatures& own) {
  const double plateau = options.confidence_plateau;
  const double spread = options.confidence_scale_spread > 0
                            ? std::hypot(options.confidence_scale_spread, options.camera_log_doubt)
                            : 0.0;
  const size_t n = location_scores.size();
  if (spread <= 0 || options.verify_scale_sigma <= 0 || candidates.empty() || n == 0) {
    return LocationPosterior(location_scores, answer, tolerance, temperature, plateau, own);
  }
  // Locations read at their own temperature (0: none), summed one by one.
  const auto own_t = [&](size_t l) { return OwnTemperature(own, static_cast<int>(l)); };
  const auto [low, high] = std::minmax_element(location_scores.begin(), location_scores.end());
  if (*low == *high) return 0;  // as LocationPosterior: nothing tells locations apart
  // Where each location's weight is read: within tolerance of the answer (counted), one
  // frame further (the plateau, not counted), or beyond at the plain temperature.
  const double flat = plateau * temperature;
  enum Zone { kNear, kRing, kFar };
  const auto zone = [&](size_t l) {
    const int offset = std::abs(static_cast<int>(l) - answer);
    return offset <= tolerance ? kNear : offset <= tolerance + 1 ? kRing : kFar;
  };
  // The verified locations' scores depend on the camera; every other location's do not: their
  // weights are summed once per zone, relative to their own top.
  std::vector<const CandidateEvidence*> verified;
  std::vector<bool> is_verified(n, false);
  for (const CandidateEvidence& c : candidates) {
    if (c.location < 0 || static_cast<size_t>(c.location) >= n || is_verified[c.location]) {
      continue;
    }
    is_verified[c.location] = true;
    verified.push_back(&c);
  }
  double other_top = -std::numeric_limits<double>::infinity();
  for (size_t l = 0; l < n; ++l) {
    if (!is_verified[l]) other_top = std::max<double>(other_top, location_scores[l]);
  }
  double other[3] = {0, 0, 0};  // per zone, sum of exp((s - other_top) / t)
  std::vector<size_t> apart;    // not verified, at their own temperature
  for (size_t l = 0; l < n; ++l) {
    if (is_verified[l]) continue;
    if (own_t(l) > 0) {
      apart.push_back(l);
      continue;
    }
    const Zone z = zone(l);
    other[z] += std::exp((location_scores[l] - other_top) / (z == kFar ? temperature : flat));
  }
  // The cameras: +-2 spreads in steps of half a spread, weighted by a normal.
  constexpr int kSteps = 4;
  std::vector<double> score(verified.size());
  double averaged = 0, weights = 0;
  for (int k = -kSteps; k <= kSteps; ++k) {
    const double x = static_cast<double>(k) / (kSteps / 2);
    const double camera = options.camera_log_scale + x * spread;
    const double weight = std::exp(-x * x / 2);
    double top = other_top;
    for (size_t i = 0; i < verified.size(); ++i) {
      score[i] = CandidateScore(*verified[i], options, camera);
      top = std::max(top, score[i]);
    }
    double near = 0, total = 0;
    if (other_top > -std::numeric_limits<double>::infinity()) {
      near = other[kNear] * std::exp((other_top - top) / flat);
      total = near + other[kRing] * std::exp((other_top - top) / flat) +
              other[kFar] * std::exp((other_top - top) / temperature);
    }
    for (size_t i = 0; i < verified.size(); ++i) {
      const size_t l = static_cast<size_t>(verified[i]->location);
      const Zone z = zone(l);
      const double t = own_t(l) > 0 ? own_t(l) : z == kFar ? temperature : flat;
      const double w = std::exp((score[i] - top) / t);
      total += w;
      if (z == kNear) near += w;
    }
    for (const size_t l : apart) total += std::exp((location_scores[l] - top) / own_t(l));
    averaged += weight * near / total;
    weights += weight;
  }
  return averaged / weights;
}

double CalibratedConfidence(const Map& map, const std::vector<float>& location_scores,
                            const std::vector<CandidateEvidence>& candidates, int answer,
                            double nearest_holistic_distance, const MatchOptions& options) {
  const double temperature = map.options.confidence_temperature;
  return CameraAveragedPosterior(location_scores, candidates, answer, map.options.tolerance,
                                 temperature, options,
                                 LookAlikeTemperatures(map, answer, temperature)) *
         InMapProbability(map, nearest_holistic_distance);
}

}  // namespace sceneloc
