// Evaluation of a map against a query folder: ours and the voting baseline on the same
// features, match rates at tolerances 0..3 frames, confidence and time per stage.
// Shared by sceneloc-eval and sceneloc-experiments.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/matching/localiser.h"
#include "common/util/status.h"

namespace sceneloc {

inline constexpr int kMaxTolerance = 3;

// query file name -> tour file name, from a CSV of `query_file,tour_file` rows (a header
// row naming the columns is allowed).
StatusOr<std::map<std::string, std::string>> ReadGroundTruth(const std::string& csv_path);

// The tour index each query should be localised to: the tour image named in
// `ground_truth`, or by default the tour image with the query's file name.
StatusOr<std::vector<int>> ResolveTruth(const std::vector<std::string>& query_names,
                                        const std::vector<std::string>& tour_names,
                                        const std::map<std::string, std::string>& ground_truth);

struct QueryOutcome {
  std::string name;
  int truth = -1;
  int predicted = -1;
  float confidence = 0;
  double extract_ms = 0;
  double match_ms = 0;
  size_t descriptor_matches = 0;
  StageTimings stages;                        // ours, per matching stage
  std::vector<CandidateEvidence> candidates;  // ours, the verified candidates
  int baseline_predicted = -1;
  float baseline_confidence = 0;
  double baseline_ms = 0;
};

struct Percentiles {
  double median = 0;
  double p90 = 0;
  double p99 = 0;
};
Percentiles ComputePercentiles(std::vector<double> values);

struct MethodSummary {
  double match_rate[kMaxTolerance + 1] = {0, 0, 0, 0};  // |predicted - truth| <= k
  double mean_confidence = 0;
  Percentiles match_ms;
};

struct EvalSummary {
  size_t queries = 0;
  MethodSummary ours;
  MethodSummary baseline;  // filled when the baseline ran
  bool has_baseline = false;
  Percentiles extract_ms;
  // Ours, per matching stage: descriptor (S_D), neighbourhood (S_N), likelihood, verify.
  Percentiles descriptor_ms, neighbourhood_ms, likelihood_ms, verify_ms;
};

// Summarises outcomes; `with_baseline` says whether the baseline fields are meaningful.
EvalSummary Summarise(const std::vector<QueryOutcome>& outcomes, bool with_baseline);

// Localises every query (already extracted) against the map with `threads` threads
// and, if `baseline_tour` is non-null, the baseline built from those tour features.
// Fills predicted/confidence/match_ms (and the baseline fields) of `outcomes`.
Status RunQueries(const std::vector<FeatureSet>& queries, const Map& map,
                  const MatchOptions& options, int threads,
                  const std::vector<FeatureSet>* baseline_tour,
                  std::vector<QueryOutcome>* outcomes);

}  // namespace sceneloc
