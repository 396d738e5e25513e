// The JSON forms shared by sceneloc-eval's and sceneloc-accuracy's reports
// (tools/eval/report_json.h): exactly the documented keys, each holding its own figure.
#include "tools/eval/report_json.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace sceneloc {
namespace {

std::set<std::string> Keys(const nlohmann::json& object) {
  std::set<std::string> keys;
  for (const auto& item : object.items()) keys.insert(item.key());
  return keys;
}

// The three percentiles, by name.
TEST(ReportJsonTest, PercentilesByName) {
  const nlohmann::json j = PercentilesJson({1.5, 2.5, 3.5});
  EXPECT_EQ(Keys(j), (std::set<std::string>{"median", "p90", "p99"}));
  EXPECT_EQ(j["median"].get<double>(), 1.5);
  EXPECT_EQ(j["p90"].get<double>(), 2.5);
  EXPECT_EQ(j["p99"].get<double>(), 3.5);
}

// Metrics whose every field holds a value of its own, so a swapped field shows.
ConfidenceMetrics DistinctMetrics() {
  ConfidenceMetrics c;
  c.queries = 40;
  c.pr_auc = 0.91;
  c.recall_at_100_precision = 0.42;
  c.ece = 0.031;
  c.ece_floor = 0.017;
  c.threshold = 0.8;
  c.correct_accepted = 0.77;
  c.accepted_precision = 0.99;
  c.accepted = 0.66;
  for (int b = 0; b < 10; ++b) {
    c.bins[static_cast<size_t>(b)] = {b + 1, b / 10.0 + 0.05, 1.0 - b / 20.0};
  }
  return c;
}

// Every documented key and no other, each with its own figure, and the ten reliability
// bins in order with their count, mean confidence and accuracy.
TEST(ReportJsonTest, ConfidenceHoldsEveryFigure) {
  const ConfidenceMetrics c = DistinctMetrics();
  const nlohmann::json j = ConfidenceJson(c);
  EXPECT_EQ(Keys(j), (std::set<std::string>{"pr_auc", "recall_at_100_precision", "ece", "ece_floor",
                                            "threshold", "correct_accepted", "accepted_precision",
                                            "accepted", "reliability_bins"}));
  EXPECT_EQ(j["pr_auc"].get<double>(), c.pr_auc);
  EXPECT_EQ(j["recall_at_100_precision"].get<double>(), c.recall_at_100_precision);
  EXPECT_EQ(j["ece"].get<double>(), c.ece);
  EXPECT_EQ(j["ece_floor"].get<double>(), c.ece_floor);
  EXPECT_EQ(j["threshold"].get<double>(), c.threshold);
  EXPECT_EQ(j["correct_accepted"].get<double>(), c.correct_accepted);
  EXPECT_EQ(j["accepted_precision"].get<double>(), c.accepted_precision);
  EXPECT_EQ(j["accepted"].get<double>(), c.accepted);
  const nlohmann::json& bins = j["reliability_bins"];
  ASSERT_TRUE(bins.is_array());
  ASSERT_EQ(bins.size(), 10u);
  for (size_t b = 0; b < 10; ++b) {
    SCOPED_TRACE("bin " + std::to_string(b));
    EXPECT_EQ(Keys(bins[b]), (std::set<std::string>{"count", "confidence", "accuracy"}));
    EXPECT_EQ(bins[b]["count"].get<int>(), c.bins[b].count);
    EXPECT_EQ(bins[b]["confidence"].get<double>(), c.bins[b].mean_confidence);
    EXPECT_EQ(bins[b]["accuracy"].get<double>(), c.bins[b].accuracy);
  }
}

// What the reports write parses back to the same figures: no NaN or infinity from metrics
// of no query (JSON has neither).
TEST(ReportJsonTest, MetricsOfNoQueryAreValidJson) {
  const ConfidenceMetrics none = ComputeConfidenceMetrics({}, {}, 0.8);
  const nlohmann::json j = ConfidenceJson(none);
  const nlohmann::json back = nlohmann::json::parse(j.dump());
  EXPECT_EQ(back, j);
  EXPECT_EQ(back["threshold"].get<double>(), 0.8);
  EXPECT_EQ(back["reliability_bins"][0]["count"].get<int>(), 0);
}

// One method's figures, the same in both reports: every documented key and no other, the
// rate at each tolerance under its own key, the timing under timing_ms.match.
TEST(ReportJsonTest, MethodHoldsEveryFigure) {
  MethodSummary m;
  for (int k = 0; k <= kMaxTolerance; ++k) m.match_rate[k] = 0.5 + k / 10.0;
  m.mean_confidence = 0.61;
  m.lean = 0.48;
  m.near_answers = 50;
  m.match_ms = {7.0, 9.0, 11.0};
  m.confidence = DistinctMetrics();
  const nlohmann::json j = MethodJson(m);
  EXPECT_EQ(Keys(j), (std::set<std::string>{"match_rate", "lean", "near_answers", "mean_confidence",
                                            "confidence", "timing_ms"}));
  ASSERT_EQ(j["match_rate"].size(), static_cast<size_t>(kMaxTolerance + 1));
  for (int k = 0; k <= kMaxTolerance; ++k) {
    EXPECT_EQ(j["match_rate"][std::to_string(k)].get<double>(), m.match_rate[k]);
  }
  EXPECT_EQ(j["lean"].get<double>(), 0.48);
  EXPECT_EQ(j["near_answers"].get<int>(), 50);
  EXPECT_EQ(j["mean_confidence"].get<double>(), 0.61);
  EXPECT_EQ(j["confidence"], ConfidenceJson(m.confidence));
  EXPECT_EQ(Keys(j["timing_ms"]), (std::set<std::string>{"match"}));
  EXPECT_EQ(j["timing_ms"]["match"], PercentilesJson(m.match_ms));
}

}  // namespace
}  // namespace sceneloc
