#include "common/matching/confidence.h"

#include <algorithm>
#include <cmath>

namespace sceneloc {

const char* ConfidenceModelName(ConfidenceModel model) {
  return model == ConfidenceModel::kPaper ? "paper" : "calibrated";
}

StatusOr<ConfidenceModel> ParseConfidenceModel(const std::string& name) {
  if (name == "calibrated") return ConfidenceModel::kCalibrated;
  if (name == "paper") return ConfidenceModel::kPaper;
  return InvalidArgument("confidence_model must be 'calibrated' or 'paper', got '" + name + "'");
}

ConfidenceModel SupportedModel(const Map& map, ConfidenceModel wanted) {
  if (wanted == ConfidenceModel::kCalibrated && !map.calibration.valid) {
    return ConfidenceModel::kPaper;
  }
  return wanted;
}

LocationTemperatures LookAlikeTemperatures(const Map& map, int answer, double temperature) {
  LocationTemperatures out;
  if (!map.has_lookalikes()) return out;
  const int n = map.num_places(), tolerance = map.options.tolerance;
  for (uint32_t k = map.lookalike_offsets[answer]; k < map.lookalike_offsets[answer + 1]; ++k) {
    const int b = static_cast<int>(map.lookalike_location[k]);
    const double rho = std::min<double>(map.lookalike_ratio[k], kMaxLookAlikeRatio);
    for (int l = std::max(0, b - tolerance); l <= std::min(n - 1, b + tolerance); ++l) {
      if (std::abs(l - answer) > tolerance + 1) out.emplace_back(l, temperature / (1 - rho));
    }
  }
  // A location near two look-alikes takes the flatter reading.
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first < b.first : a.second > b.second;
  });
  out.erase(std::unique(out.begin(), out.end(),
                        [](const auto& a, const auto& b) { return a.first == b.first; }),
            out.end());
  return out;
}

double OwnTemperature(const LocationTemperatures& own, int l) {
  const auto at = std::lower_bound(own.begin(), own.end(), l, [](const auto& entry, int location) {
    return entry.first < location;
  });
  return at != own.end() && at->first == l ? at->second : 0.0;
}

double LocationPosterior(const std::vector<float>& location_scores, int answer, int tolerance,
                         double temperature, double plateau, const LocationTemperatures& own) {
  if (location_scores.empty()) return 0;
  const auto [low, high] = std::minmax_element(location_scores.begin(), location_scores.end());
  if (*low == *high) return 0;  // no evidence tells any location from another
  const float top = *high;
  const double flat = plateau * temperature;
  double total = 0, near = 0;
  for (size_t l = 0; l < location_scores.size(); ++l) {
    const int offset = std::abs(static_cast<int>(l) - answer);
    double t = offset <= tolerance + 1 ? flat : temperature;
    if (const double own_t = OwnTemperature(own, static_cast<int>(l)); own_t > 0) t = own_t;
    const double w = std::exp((location_scores[l] - top) / t);  // <= 1: no overflow
    total += w;
    if (offset <= tolerance) near += w;
  }
  return near / total;
}

double InMapProbability(const Map& map, double nearest_holistic_distance) {
  return InMapProbability(map, map.calibration, nearest_holistic_distance);
}

double InMapProbability(const Map& map, const Calibration& c, double nearest_holistic_distance) {
  if (!c.valid || nearest_holistic_distance < 0) return 1;
  const double x = (c.off_map_distance - nearest_holistic_distance) / c.off_map_spread;
  return 1 /
         (1 + std::exp(-(map.options.map_evidence_slope * x + map.options.map_evidence_offset)));
}

double PaperConfidence(const std::vector<float>& likelihood) {
  if (likelihood.empty()) return 0;
  if (likelihood.size() == 1) return likelihood[0] > 0 ? 1 : 0;
  std::vector<float> top(2);
  std::partial_sort_copy(likelihood.begin(), likelihood.end(), top.begin(), top.end(),
                         std::greater<float>());
  const double sum = static_cast<double>(top[0]) + top[1];
  return sum > 0 ? top[0] / sum : 0;
}

}  // namespace sceneloc
