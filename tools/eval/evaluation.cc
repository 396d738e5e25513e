#include "tools/eval/evaluation.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <utility>

#include "common/matching/baseline.h"
#include "common/matching/sequence_filter.h"
#include "common/util/thread_pool.h"
#include "common/util/timer.h"

namespace sceneloc {

namespace {

std::string Trimmed(const std::string& text) {
  const size_t first = text.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return text.substr(first, text.find_last_not_of(" \t") - first + 1);
}

}  // namespace

StatusOr<std::map<std::string, std::string>> ReadGroundTruth(const std::string& csv_path) {
  std::ifstream in(csv_path);
  if (!in) return NotFound("ground-truth file '" + csv_path + "' cannot be opened");
  std::map<std::string, std::string> truth;
  std::map<std::string, int> line_of;
  std::string line;
  int line_number = 0;
  bool first_row = true;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (Trimmed(line).empty() || line[0] == '#') continue;
    const std::string where = csv_path + ":" + std::to_string(line_number) + ": ";
    const size_t comma = line.find(',');
    if (comma == std::string::npos || line.find(',', comma + 1) != std::string::npos) {
      return InvalidArgument(where + "expected 'query_file,tour_file'");
    }
    const std::string query = Trimmed(line.substr(0, comma));
    const std::string tour = Trimmed(line.substr(comma + 1));
    // The header, if any, is the first row (comments and blank lines may come before it).
    if (std::exchange(first_row, false) && query == "query_file" && tour == "tour_file") continue;
    if (query.empty() || tour.empty()) return InvalidArgument(where + "an empty file name");
    const auto [it, added] = line_of.emplace(query, line_number);
    if (!added) {
      return InvalidArgument(where + "query '" + query + "' is listed again (first on line " +
                             std::to_string(it->second) + ")");
    }
    truth[query] = tour;
  }
  if (truth.empty()) return InvalidArgument("ground-truth file '" + csv_path + "' has no row");
  return truth;
}

StatusOr<std::vector<int>> ResolveTruth(const std::vector<std::string>& query_names,
                                        const std::vector<std::string>& tour_names,
                                        const std::map<std::string, std::string>& ground_truth) {
  std::map<std::string, int> index_of;
  for (size_t i = 0; i < tour_names.size(); ++i) index_of[tour_names[i]] = static_cast<int>(i);
  std::vector<int> truth;
  for (const std::string& q : query_names) {
    std::string tour_name = q;
    if (!ground_truth.empty()) {
      const auto it = ground_truth.find(q);
      if (it == ground_truth.end()) return NotFound("query '" + q + "' has no ground-truth row");
      tour_name = it->second;
    }
    const auto it = index_of.find(tour_name);
    if (it == index_of.end()) {
      return NotFound("query '" + q + "': its true location '" + tour_name +
                      "' is not a tour image of this map");
    }
    truth.push_back(it->second);
  }
  return truth;
}

Percentiles ComputePercentiles(std::vector<double> values) {
  Percentiles p;
  if (values.empty()) return p;
  std::sort(values.begin(), values.end());
  // Nearest-rank percentiles: an observed value, never an interpolation.
  const auto rank = [&](double q) {
    const size_t r = static_cast<size_t>(std::ceil(q * static_cast<double>(values.size())));
    return values[std::min(values.size() - 1, r == 0 ? 0 : r - 1)];
  };
  p.median = rank(0.5);
  p.p90 = rank(0.9);
  p.p99 = rank(0.99);
  return p;
}

const char* MethodName(Method method) {
  switch (method) {
    case Method::kOurs:
      return "sceneloc";
    case Method::kBaseline:
      return "baseline";
    case Method::kReranked:
      return "baseline+ransac";
  }
  return "";
}

const MethodOutcome& OutcomeOf(const QueryOutcome& o, Method method) {
  switch (method) {
    case Method::kBaseline:
      return o.baseline;
    case Method::kReranked:
      return o.reranked;
    case Method::kOurs:
      break;
  }
  return o.ours;
}

MethodSummary SummariseMethod(const std::vector<QueryOutcome>& outcomes, Method method,
                              const Judging& judging) {
  MethodSummary m;
  std::vector<double> times;
  std::vector<float> confidence;
  std::vector<bool> correct;
  for (const QueryOutcome& o : outcomes) {
    const MethodOutcome& r = OutcomeOf(o, method);
    for (int k = 0; k <= kMaxTolerance; ++k) {
      if (r.predicted >= 0 && std::abs(r.predicted - o.truth) <= k) m.match_rate[k] += 1;
    }
    if (r.predicted >= 0 && std::abs(r.predicted - o.truth) <= MethodSummary::kLeanWindow) {
      m.lean += r.predicted - o.truth;
      ++m.near_answers;
    }
    m.mean_confidence += r.confidence;
    times.push_back(r.ms);
    confidence.push_back(r.confidence);
    correct.push_back(r.predicted >= 0 && std::abs(r.predicted - o.truth) <= judging.tolerance);
  }
  m.confidence = ComputeConfidenceMetrics(confidence, correct, judging.threshold);
  const double n = std::max<double>(1, static_cast<double>(outcomes.size()));
  for (double& r : m.match_rate) r /= n;
  m.mean_confidence /= n;
  if (m.near_answers > 0) m.lean /= m.near_answers;
  m.match_ms = ComputePercentiles(times);
  return m;
}

EvalSummary Summarise(const std::vector<QueryOutcome>& outcomes, bool with_baseline,
                      const Judging& judging) {
  EvalSummary s;
  s.queries = outcomes.size();
  s.ours = SummariseMethod(outcomes, Method::kOurs, judging);
  if (with_baseline) {
    s.baseline = SummariseMethod(outcomes, Method::kBaseline, judging);
    s.reranked = SummariseMethod(outcomes, Method::kReranked, judging);
  }
  s.has_baseline = with_baseline;
  const auto stage = [&](auto field) {
    std::vector<double> values;
    for (const QueryOutcome& o : outcomes) values.push_back(field(o));
    return ComputePercentiles(values);
  };
  s.extract_ms = stage([](const QueryOutcome& o) { return o.extract_ms; });
  s.place_ms = stage([](const QueryOutcome& o) { return o.stages.place_ms; });
  s.descriptor_ms = stage([](const QueryOutcome& o) { return o.stages.descriptor_ms; });
  s.neighbourhood_ms = stage([](const QueryOutcome& o) { return o.stages.neighbourhood_ms; });
  s.likelihood_ms = stage([](const QueryOutcome& o) { return o.stages.likelihood_ms; });
  s.holistic_ms = stage([](const QueryOutcome& o) { return o.stages.holistic_ms; });
  s.verify_ms = stage([](const QueryOutcome& o) { return o.stages.verify_ms; });
  return s;
}

namespace {

// The callers size the outcomes (name and truth filled) before running: one per query.
Status CheckOutcomes(const std::vector<FeatureSet>& queries,
                     const std::vector<QueryOutcome>* outcomes) {
  if (outcomes != nullptr && outcomes->size() == queries.size()) return Status::Ok();
  return InvalidArgument(std::to_string(queries.size()) + " queries but " +
                         std::to_string(outcomes == nullptr ? 0 : outcomes->size()) +
                         " outcomes to fill");
}

}  // namespace

LocaliseResult KeptResult(const QueryOutcome& o) {
  LocaliseResult r;
  r.ranked = o.ranked;
  r.candidates = o.candidates;
  r.location_scores = o.location_scores;
  r.nearest_holistic_distance = o.nearest_holistic_distance;
  r.confidence = o.ours.confidence;
  return r;
}

Status RunOurs(const std::vector<FeatureSet>& queries, const Map& map, const MatchOptions& options,
               int threads, std::vector<QueryOutcome>* outcomes) {
  SCENELOC_RETURN_IF_ERROR(CheckOutcomes(queries, outcomes));
  ThreadPool pool(threads);
  for (size_t q = 0; q < queries.size(); ++q) {
    Stopwatch watch;
    SCENELOC_ASSIGN_OR_RETURN(const LocaliseResult r, Localise(queries[q], map, options, &pool));
    QueryOutcome& o = (*outcomes)[q];
    o.ours.ms = watch.Milliseconds();
    o.ours.predicted = r.ranked.empty() ? -1 : r.ranked[0].index;
    o.ours.confidence = r.confidence;
    o.descriptor_matches = r.descriptor_matches;
    o.stages = r.timings;
    o.candidates = r.candidates;
    o.location_scores = r.location_scores;
    o.in_map = r.nearest_holistic_distance >= 0 && map.calibration.valid
                   ? InMapProbability(map, r.nearest_holistic_distance)
                   : -1;
    o.ranked = r.ranked;
    o.camera_log_scale = r.camera_log_scale;
    o.camera_log_doubt = r.camera_log_doubt;
    o.nearest_holistic_distance = r.nearest_holistic_distance;
    o.keypoints = queries[q].size();
  }
  return Status::Ok();
}

Status RunBaselines(const std::vector<FeatureSet>& queries, const std::vector<FeatureSet>& tour,
                    double ransac_threshold, std::vector<QueryOutcome>* outcomes) {
  SCENELOC_RETURN_IF_ERROR(CheckOutcomes(queries, outcomes));
  BaselineOptions options;
  if (!tour.empty()) {
    options.ransac_threshold_px =
        ransac_threshold * std::max(tour.front().image_width, tour.front().image_height);
  }
  SCENELOC_ASSIGN_OR_RETURN(auto baseline, VotingBaseline::Build(tour, options));
  for (size_t q = 0; q < queries.size(); ++q) {
    Stopwatch watch;
    const BaselineResult r = baseline->Localise(queries[q]);
    const double ms = watch.Milliseconds();
    QueryOutcome& o = (*outcomes)[q];
    o.baseline = {r.best, r.confidence, ms - r.rerank_ms};
    o.reranked = {r.reranked_best, r.reranked_confidence, ms};
  }
  return Status::Ok();
}

Status RunQueries(const std::vector<FeatureSet>& queries, const Map& map,
                  const MatchOptions& options, int threads,
                  const std::vector<FeatureSet>* baseline_tour,
                  std::vector<QueryOutcome>* outcomes) {
  SCENELOC_RETURN_IF_ERROR(RunOurs(queries, map, options, threads, outcomes));
  if (baseline_tour == nullptr) return Status::Ok();
  return RunBaselines(queries, *baseline_tour, options.verify_ransac_threshold, outcomes);
}

}  // namespace sceneloc
