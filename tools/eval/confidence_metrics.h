// How well a confidence tells right answers from wrong ones, as VPR-Bench measures it:
// the precision-recall curve of the top-1 answers ranked by confidence (a query is
// correct when its answer is within the tolerance), its area, the recall at 100%
// precision, and the expected calibration error (10 equal-width bins) with its
// reliability diagram.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace sceneloc {

struct ReliabilityBin {
  int count = 0;
  double mean_confidence = 0;
  double accuracy = 0;
};

struct ConfidenceMetrics {
  int queries = 0;
  double accuracy = 0;  // share of correct answers
  double mean_confidence = 0;
  // Area under the precision-recall curve (scikit-learn's precision_recall_curve, then the
  // trapezoidal area), and the largest recall at precision 1.
  double pr_auc = 0;
  double recall_at_100_precision = 0;
  // Expected calibration error over 10 equal-width bins, and the ECE a perfectly calibrated
  // confidence would show on as many queries with these confidences (its expectation over
  // simulated outcomes): below about that floor a measured ECE says nothing.
  double ece = 0;
  double ece_floor = 0;
  std::array<ReliabilityBin, 10> bins;
  // At the decision threshold: the share of correct answers accepted, the precision of the
  // accepted, and the share of all answers accepted.
  double threshold = 0;
  double correct_accepted = 0;
  double accepted_precision = 0;
  double accepted = 0;
};

// `confidence[i]` is query i's score for its answer, `correct[i]` whether the answer is
// within the tolerance. REQUIRES: equal sizes.
ConfidenceMetrics ComputeConfidenceMetrics(const std::vector<float>& confidence,
                                           const std::vector<bool>& correct, double threshold,
                                           uint32_t seed = 1);

// Points (recall, precision) of the precision-recall curve, recall increasing, as
// scikit-learn's precision_recall_curve returns them (reversed).
struct PrPoint {
  double recall;
  double precision;
};
std::vector<PrPoint> PrecisionRecallCurve(const std::vector<float>& score,
                                          const std::vector<bool>& correct);

}  // namespace sceneloc
