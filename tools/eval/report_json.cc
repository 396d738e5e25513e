#include "tools/eval/report_json.h"

#include <string>

namespace sceneloc {

nlohmann::json PercentilesJson(const Percentiles& p) {
  return {{"median", p.median}, {"p90", p.p90}, {"p99", p.p99}};
}

nlohmann::json ConfidenceJson(const ConfidenceMetrics& c) {
  nlohmann::json bins = nlohmann::json::array();
  for (const ReliabilityBin& b : c.bins) {
    bins.push_back(
        {{"count", b.count}, {"confidence", b.mean_confidence}, {"accuracy", b.accuracy}});
  }
  return {{"pr_auc", c.pr_auc},
          {"recall_at_100_precision", c.recall_at_100_precision},
          {"ece", c.ece},
          {"ece_floor", c.ece_floor},
          {"threshold", c.threshold},
          {"correct_accepted", c.correct_accepted},
          {"accepted_precision", c.accepted_precision},
          {"accepted", c.accepted},
          {"reliability_bins", bins}};
}

nlohmann::json MethodJson(const MethodSummary& m) {
  nlohmann::json rates;
  for (int k = 0; k <= kMaxTolerance; ++k) rates[std::to_string(k)] = m.match_rate[k];
  return {{"match_rate", rates},
          {"lean", m.lean},
          {"near_answers", m.near_answers},
          {"mean_confidence", m.mean_confidence},
          {"confidence", ConfidenceJson(m.confidence)},
          {"timing_ms", {{"match", PercentilesJson(m.match_ms)}}}};
}

}  // namespace sceneloc
