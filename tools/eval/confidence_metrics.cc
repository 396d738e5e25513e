#include "tools/eval/confidence_metrics.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace sceneloc {
namespace {

// Bin b holds [b/10, (b+1)/10); the epsilon keeps a float 0.7f (0.69999998...) in bin 7.
int BinOf(double confidence) { return std::clamp(static_cast<int>(confidence * 10 + 1e-6), 0, 9); }

// ECE of outcomes `correct` with confidences `confidence`; fills `bins` when not null.
double Ece(const std::vector<float>& confidence, const std::vector<bool>& correct,
           std::array<ReliabilityBin, 10>* bins) {
  std::array<ReliabilityBin, 10> b{};
  for (size_t i = 0; i < confidence.size(); ++i) {
    ReliabilityBin& bin = b[static_cast<size_t>(BinOf(confidence[i]))];
    ++bin.count;
    bin.mean_confidence += confidence[i];
    bin.accuracy += correct[i] ? 1 : 0;
  }
  double ece = 0;
  for (ReliabilityBin& bin : b) {
    if (bin.count == 0) continue;
    bin.mean_confidence /= bin.count;
    bin.accuracy /= bin.count;
    ece += static_cast<double>(bin.count) / confidence.size() *
           std::abs(bin.accuracy - bin.mean_confidence);
  }
  if (bins != nullptr) *bins = b;
  return ece;
}

}  // namespace

std::vector<PrPoint> PrecisionRecallCurve(const std::vector<float>& score,
                                          const std::vector<bool>& correct) {
  const size_t n = score.size();
  const double positives = static_cast<double>(std::count(correct.begin(), correct.end(), true));
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return score[a] > score[b]; });
  // One point per distinct threshold, from the highest score down, stopping once every
  // positive is recalled (as scikit-learn does).
  std::vector<PrPoint> points;
  double tp = 0, fp = 0;
  for (size_t i = 0; i < n; ++i) {
    (correct[order[i]] ? tp : fp) += 1;
    if (i + 1 < n && score[order[i + 1]] == score[order[i]]) continue;
    if (positives == 0) break;
    points.push_back({tp / positives, tp / (tp + fp)});
    if (tp == positives) break;
  }
  points.insert(points.begin(), {0.0, 1.0});
  return points;
}

ConfidenceMetrics ComputeConfidenceMetrics(const std::vector<float>& confidence,
                                           const std::vector<bool>& correct, double threshold,
                                           uint32_t seed) {
  ConfidenceMetrics m;
  m.queries = static_cast<int>(confidence.size());
  m.threshold = threshold;
  if (confidence.empty()) return m;
  const double n = static_cast<double>(confidence.size());
  int right = 0, accepted = 0, accepted_right = 0;
  for (size_t i = 0; i < confidence.size(); ++i) {
    right += correct[i];
    m.mean_confidence += confidence[i] / n;
    if (confidence[i] >= threshold) {
      ++accepted;
      accepted_right += correct[i];
    }
  }
  m.accuracy = right / n;
  m.accepted = accepted / n;
  m.correct_accepted = right > 0 ? static_cast<double>(accepted_right) / right : 0;
  m.accepted_precision = accepted > 0 ? static_cast<double>(accepted_right) / accepted : 1;

  const std::vector<PrPoint> curve = PrecisionRecallCurve(confidence, correct);
  for (size_t i = 1; i < curve.size(); ++i) {
    m.pr_auc +=
        (curve[i].recall - curve[i - 1].recall) * (curve[i].precision + curve[i - 1].precision) / 2;
    if (curve[i].precision >= 1.0) m.recall_at_100_precision = curve[i].recall;
  }
  m.ece = Ece(confidence, correct, &m.bins);

  // The floor: outcomes drawn as a perfectly calibrated confidence predicts them.
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  constexpr int kDraws = 200;
  std::vector<bool> simulated(confidence.size());
  for (int d = 0; d < kDraws; ++d) {
    for (size_t i = 0; i < confidence.size(); ++i) simulated[i] = u(rng) < confidence[i];
    m.ece_floor += Ece(confidence, simulated, nullptr) / kDraws;
  }
  return m;
}

}  // namespace sceneloc
