#include "tools/eval/confidence_metrics.h"

#include <gtest/gtest.h>

namespace sceneloc {
namespace {

// PR-AUC, recall at 100% precision and ECE equal what scikit-learn computes for the same
// ten answers (precision_recall_curve + auc; 10 equal-width bins).
TEST(ConfidenceMetricsTest, MatchesScikitLearn) {
  const std::vector<bool> correct = {true, true, false, true, false, true, true, false, true, true};
  const std::vector<float> score = {0.9f, 0.8f, 0.75f, 0.7f, 0.6f, 0.6f, 0.5f, 0.4f, 0.3f, 0.2f};
  const ConfidenceMetrics m = ComputeConfidenceMetrics(score, correct, 0.65);
  EXPECT_NEAR(m.pr_auc, 0.7766156, 1e-5);
  EXPECT_NEAR(m.recall_at_100_precision, 2.0 / 7.0, 1e-9);
  EXPECT_NEAR(m.ece, 0.335, 1e-5);
  EXPECT_NEAR(m.accuracy, 0.7, 1e-9);
  // Accepted at 0.65: the four highest, three of them correct, of seven correct in all.
  EXPECT_NEAR(m.accepted, 0.4, 1e-9);
  EXPECT_NEAR(m.accepted_precision, 0.75, 1e-9);
  EXPECT_NEAR(m.correct_accepted, 3.0 / 7.0, 1e-9);
  int counted = 0;
  for (const ReliabilityBin& b : m.bins) counted += b.count;
  EXPECT_EQ(counted, 10);
  EXPECT_EQ(m.bins[6].count, 2);  // 0.6 and 0.6
  EXPECT_NEAR(m.bins[6].accuracy, 0.5, 1e-9);
}

// A confidence that ranks every right answer above every wrong one: PR-AUC and recall at
// 100% precision are 1; a perfectly calibrated confidence has an ECE near its floor.
TEST(ConfidenceMetricsTest, PerfectSeparationAndCalibration) {
  std::vector<float> score;
  std::vector<bool> correct;
  for (int i = 0; i < 1000; ++i) {
    score.push_back(i < 900 ? 0.9f : 0.1f);
    correct.push_back(i < 810 || (i >= 900 && i < 910));  // 90% and 10% right
  }
  const ConfidenceMetrics m = ComputeConfidenceMetrics(score, correct, 0.5);
  EXPECT_NEAR(m.ece, 0.0, 1e-6);
  EXPECT_GT(m.ece_floor, 0.0);
  EXPECT_LT(m.ece_floor, 0.03);
  std::vector<float> ranked = {0.9f, 0.8f, 0.3f, 0.2f};
  const ConfidenceMetrics sep = ComputeConfidenceMetrics(ranked, {true, true, false, false}, 0.5);
  EXPECT_NEAR(sep.pr_auc, 1.0, 1e-9);
  EXPECT_NEAR(sep.recall_at_100_precision, 1.0, 1e-9);
}

// No answers, or no right answer, give zeros rather than NaNs.
TEST(ConfidenceMetricsTest, DegenerateInputs) {
  const ConfidenceMetrics none = ComputeConfidenceMetrics({}, {}, 0.5);
  EXPECT_EQ(none.queries, 0);
  const ConfidenceMetrics wrong = ComputeConfidenceMetrics({0.9f, 0.2f}, {false, false}, 0.5);
  EXPECT_EQ(wrong.pr_auc, 0.0);
  EXPECT_EQ(wrong.recall_at_100_precision, 0.0);
  EXPECT_EQ(wrong.correct_accepted, 0.0);
}

}  // namespace
}  // namespace sceneloc
