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
#include "tools/eval/confidence_metrics.h"

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

// One method's answer to one query.
struct MethodOutcome {
  int predicted = -1;    // tour index, -1 for no answer
  float confidence = 0;  // the method's own score for its answer (higher = surer)
  double ms = 0;         // matching time
};

struct QueryOutcome {
  std::string name;
  int truth = -1;
  double extract_ms = 0;
  MethodOutcome ours;
  size_t descriptor_matches = 0;
  StageTimings stages;                        // ours, per matching stage
  std::vector<CandidateEvidence> candidates;  // ours, the verified candidates
  std::vector<float> location_scores;         // ours, every location's fused evidence
  double in_map = -1;                         // ours, P(in the map); -1 unknown
  std::vector<RankedLocation> ranked;         // ours, the ranked answer
  float nearest_holistic_distance = -1;       // ours, LocaliseResult's
  double camera_log_scale = 0;                // ours, the camera it was read with, and
  double camera_log_doubt = 0;                // its doubt (LocaliseResult's)
  int keypoints = 0;                          // the query's feature count
  MethodOutcome baseline;                     // FLANN votes (when the baselines ran)
  MethodOutcome reranked;                     // the same, top 10 re-ranked by RANSAC inliers
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
  // Which way the near answers lean: the mean of predicted - truth over the near_answers
  // answers within kLeanWindow frames of the truth (0 when none). A lean shared by every
  // method says the ground truth is offset from what the queries show; ours alone, a bias
  // of ours (docs/results.md "Which way the near answers lean").
  double lean = 0;
  int near_answers = 0;
  static constexpr int kLeanWindow = 5;
  Percentiles match_ms;
  // How well the confidence separates answers within the tolerance from the others, and
  // its acceptance at the decision threshold (confidence_metrics.h).
  ConfidenceMetrics confidence;
};

// How answers are judged: correct within `tolerance` frames; accepted at `threshold`.
struct Judging {
  int tolerance = 2;
  double threshold = 0.8;
};

// Which method of a QueryOutcome.
enum class Method { kOurs, kBaseline, kReranked };
const char* MethodName(Method method);
const MethodOutcome& OutcomeOf(const QueryOutcome& o, Method method);

struct EvalSummary {
  size_t queries = 0;
  MethodSummary ours;
  MethodSummary baseline;  // filled when the baselines ran
  MethodSummary reranked;
  bool has_baseline = false;
  Percentiles extract_ms;
  // Ours, per matching stage: descriptor (S_D), neighbourhood (S_N), likelihood, holistic,
  // verify.
  Percentiles place_ms, descriptor_ms, neighbourhood_ms, likelihood_ms, holistic_ms, verify_ms;
};

MethodSummary SummariseMethod(const std::vector<QueryOutcome>& outcomes, Method method,
                              const Judging& judging = {});

// Summarises outcomes; `with_baseline` says whether the baseline fields are meaningful.
EvalSummary Summarise(const std::vector<QueryOutcome>& outcomes, bool with_baseline,
                      const Judging& judging = {});

// What of Localise's result `o` keeps (the ranking, candidates, location scores, nearest
// holistic distance and confidence): enough for ReadWithCamera to read it again.
LocaliseResult KeptResult(const QueryOutcome& o);

// Localises every query (already extracted) against the map with `threads` threads and
// fills outcome.ours (and the stages, matches and candidates). `outcomes` holds one entry per
// query (InvalidArgument otherwise, before any work), as for RunBaselines.
Status RunOurs(const std::vector<FeatureSet>& queries, const Map& map, const MatchOptions& options,
               int threads, std::vector<QueryOutcome>* outcomes);

// Runs both baselines built from `tour` (the map's tour, extracted as the map's) and fills
// outcome.baseline and outcome.reranked. The RANSAC threshold is the map frame's fraction
// `ransac_threshold` (as verify_ransac_threshold).
Status RunBaselines(const std::vector<FeatureSet>& queries, const std::vector<FeatureSet>& tour,
                    double ransac_threshold, std::vector<QueryOutcome>* outcomes);

// RunOurs, then RunBaselines when `baseline_tour` is not null.
Status RunQueries(const std::vector<FeatureSet>& queries, const Map& map,
                  const MatchOptions& options, int threads,
                  const std::vector<FeatureSet>* baseline_tour,
                  std::vector<QueryOutcome>* outcomes);

}  // namespace sceneloc
