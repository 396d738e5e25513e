// The JSON forms of the evaluation figures that sceneloc-eval and sceneloc-accuracy both
// write, so the two reports spell every field the same way.
#pragma once

#include <nlohmann/json.hpp>

#include "tools/eval/confidence_metrics.h"
#include "tools/eval/evaluation.h"

namespace sceneloc {

// {"median", "p90", "p99"}
nlohmann::json PercentilesJson(const Percentiles& p);

// {"pr_auc", "recall_at_100_precision", "ece", "ece_floor", "threshold", "correct_accepted",
//  "accepted_precision", "accepted", "reliability_bins": [{"count", "confidence", "accuracy"}]}
nlohmann::json ConfidenceJson(const ConfidenceMetrics& c);

// One method's figures: {"match_rate": {"0".."kMaxTolerance"}, "lean", "near_answers",
//  "mean_confidence", "confidence": ConfidenceJson, "timing_ms": {"match": PercentilesJson}}
nlohmann::json MethodJson(const MethodSummary& m);

}  // namespace sceneloc
