#include "tools/eval/eval_report.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "common/matching/sequence_filter.h"
#include "tools/eval/report_json.h"

namespace sceneloc {
namespace {

nlohmann::json QueryJson(const QueryOutcome& o, bool with_baseline) {
  nlohmann::json q = {{"query", o.name},
                      {"truth", o.truth},
                      {"predicted", o.ours.predicted},
                      {"confidence", o.ours.confidence},
                      {"extract_ms", o.extract_ms},
                      {"match_ms", o.ours.ms},
                      {"keypoints", o.keypoints},
                      {"descriptor_matches", o.descriptor_matches},
                      {"location_scores", o.location_scores},
                      {"in_map", o.in_map},
                      {"candidates", nlohmann::json::array()}};
  if (with_baseline) {
    q["baseline_predicted"] = o.baseline.predicted;
    q["baseline_confidence"] = o.baseline.confidence;
    q["baseline_reranked_predicted"] = o.reranked.predicted;
    q["baseline_reranked_confidence"] = o.reranked.confidence;
  }
  for (const CandidateEvidence& c : o.candidates) {
    q["candidates"].push_back({{"location", c.location},
                               {"likelihood", c.likelihood},
                               {"holistic", c.holistic},
                               {"holistic_rank", c.holistic_rank},
                               {"holistic_z", c.holistic_z},
                               {"correspondences", c.correspondences},
                               {"inliers", c.inliers},
                               {"log_scale", c.log_scale},
                               {"score", c.score}});
  }
  return q;
}

nlohmann::json RelocalisationJson(const std::vector<int>& frames) {
  std::vector<double> values(frames.begin(), frames.end());
  const Percentiles p = ComputePercentiles(values);
  return {{"per_jump", frames},
          {"median", p.median},
          {"max", frames.empty() ? 0 : *std::max_element(frames.begin(), frames.end())}};
}

nlohmann::json SessionJson(const SessionReport& r) {
  nlohmann::json j = {{"single_frame", MethodJson(r.single)},
                      {"in_session", MethodJson(r.in_session)},
                      {"filter_ms_median", r.run->filter_ms_median},
                      {"kidnap_segments", r.kidnap},
                      {"reversed", r.reversed}};
  if (r.kidnap > 1) {
    j["frames_to_correct"] = RelocalisationJson(r.run->relocalisation.to_correct);
    j["frames_to_localised"] = RelocalisationJson(r.run->relocalisation.to_localised);
  }
  return j;
}

void PrintMethod(const char* name, const MethodSummary& m, int tolerance) {
  std::printf(
      "%-9s  %5.3f  %5.3f  %5.3f  %5.3f   %5.3f       %7.2f  %7.2f   (headline ±%d: %.3f)\n", name,
      m.match_rate[0], m.match_rate[1], m.match_rate[2], m.match_rate[3], m.mean_confidence,
      m.match_ms.median, m.match_ms.p90, tolerance, m.match_rate[tolerance]);
}

void PrintConfidence(const char* name, const MethodSummary& m) {
  const ConfidenceMetrics& c = m.confidence;
  std::printf("%-9s  %6.3f  %6.2f  %5.3f (%5.3f)   %5.2f            %5.2f\n", name, c.pr_auc,
              c.recall_at_100_precision, c.ece, c.ece_floor, c.correct_accepted,
              c.accepted_precision);
}

void PrintRelocalisation(const char* what, const std::vector<int>& frames) {
  if (frames.empty()) return;
  std::vector<double> values(frames.begin(), frames.end());
  std::printf("  frames to %s after a jump: median %.1f, max %d, over %zu jumps\n", what,
              ComputePercentiles(values).median, *std::max_element(frames.begin(), frames.end()),
              frames.size());
}

// The heading, then match rates and confidence per method.
void PrintTables(const EvalReport& r) {
  const EvalSummary& s = *r.summary;
  const Map& map = *r.map;
  const MatchOptions& options = *r.options;
  const SessionReport* session = r.session;
  std::printf("map %s: %d locations, %d landmarks, %.1f MB in memory, loaded in %.1f ms\n",
              r.map_path.c_str(), map.num_images(), map.num_landmarks(),
              static_cast<double>(map.MemoryBytes()) / 1e6, r.load_ms);
  std::printf("%zu queries from %s, %d matching thread(s)\n", s.queries, r.queries_dir.c_str(),
              r.threads);
  std::printf("method     exact   ±1     ±2     ±3     confidence  match ms (median  p90)\n");
  PrintMethod("sceneloc", s.ours, r.tolerance);
  if (session != nullptr) {
    PrintMethod("single", session->single, r.tolerance);
    PrintMethod("in sess.", session->in_session, r.tolerance);
  }
  if (r.with_baseline) {
    PrintMethod("baseline", s.baseline, r.tolerance);
    PrintMethod("+ransac", s.reranked, r.tolerance);
  }
  const auto model = SupportedModel(map, *ParseConfidenceModel(options.confidence_model));
  std::printf(
      "confidence (%s model; correct = within ±%d; accepted = confidence >= %.2f; baselines: "
      "vote or inlier share)\n",
      ConfidenceModelName(model), map.options.tolerance, options.min_confidence);
  std::printf("method     PR-AUC  R@100P  ECE (floor)     correct accepted  precision\n");
  PrintConfidence("sceneloc", s.ours);
  if (session != nullptr) {
    PrintConfidence("single", session->single);
    PrintConfidence("in sess.", session->in_session);
  }
  if (r.with_baseline) {
    PrintConfidence("baseline", s.baseline);
    PrintConfidence("+ransac", s.reranked);
  }
}

// The negatives' and the session's lines, when they ran.
void PrintNegativesAndSession(const EvalReport& r) {
  const Negatives* negatives = r.negatives;
  const SessionReport* session = r.session;
  if (negatives != nullptr) {
    std::printf("negatives: %zu frames from %s, %zu LOCALISED (%.1f%%), largest confidence %.2f\n",
                negatives->frames, r.negatives_dir.c_str(), negatives->accepted,
                100.0 * negatives->accepted / std::max<size_t>(1, negatives->frames),
                negatives->max_confidence);
  }
  if (session != nullptr) {
    const SequenceFilter filter(*r.map, r.options->sequence);
    std::printf(
        "session: the queries in %s as one session (sceneloc row; single = the same frames one "
        "by one; in sess. = each frame's own answer in the session, read with its camera); speeds "
        "up to %d locations per frame up the route, %d down it, filter %.3f ms "
        "per frame\n",
        (std::string(session->reversed ? "reverse file order" : "file order") +
         (session->kidnap > 1 ? ", in " + std::to_string(session->kidnap) + " shuffled segments"
                              : ""))
            .c_str(),
        filter.max_forward(), filter.max_backward(), session->run->filter_ms_median);
    PrintRelocalisation("a correct answer", session->run->relocalisation.to_correct);
    PrintRelocalisation("a correct LOCALISED answer", session->run->relocalisation.to_localised);
  }
}

}  // namespace

nlohmann::json ReportJson(const EvalReport& r) {
  const EvalSummary& s = *r.summary;
  const std::vector<QueryOutcome>& out = *r.outcomes;
  const Map& map = *r.map;
  const MatchOptions& options = *r.options;
  const Negatives* negatives = r.negatives;
  const SessionReport* session = r.session;
  nlohmann::json j = MethodJson(s.ours);
  j["queries"] = s.queries;
  j["confidence_model"] =
      ConfidenceModelName(SupportedModel(map, *ParseConfidenceModel(options.confidence_model)));
  j["timing_ms"] = {{"extract", PercentilesJson(s.extract_ms)},
                    {"match", PercentilesJson(s.ours.match_ms)},
                    {"place", PercentilesJson(s.place_ms)},
                    {"descriptor", PercentilesJson(s.descriptor_ms)},
                    {"neighbourhood", PercentilesJson(s.neighbourhood_ms)},
                    {"likelihood", PercentilesJson(s.likelihood_ms)},
                    {"holistic", PercentilesJson(s.holistic_ms)},
                    {"verify", PercentilesJson(s.verify_ms)},
                    {"map_load", r.load_ms}};
  j["map_memory_bytes"] = map.MemoryBytes();
  if (s.has_baseline) {
    j["baseline"] = MethodJson(s.baseline);
    j["baseline_reranked"] = MethodJson(s.reranked);
  }
  if (negatives != nullptr) {
    j["negatives"] = {{"frames", negatives->frames},
                      {"accepted", negatives->accepted},
                      {"max_confidence", negatives->max_confidence}};
  }
  if (session != nullptr) j["session"] = SessionJson(*session);
  j["per_query"] = nlohmann::json::array();
  for (size_t q = 0; q < out.size(); ++q) {
    nlohmann::json query = QueryJson(out[q], s.has_baseline);
    if (session != nullptr) {
      query["single_predicted"] = session->single_outcomes[q].ours.predicted;
      query["single_confidence"] = session->single_outcomes[q].ours.confidence;
    }
    j["per_query"].push_back(std::move(query));
  }
  return j;
}

void PrintAnswers(const std::vector<QueryOutcome>& outcomes,
                  const std::vector<std::string>& tour_names, int tolerance, double threshold) {
  for (const auto& o : outcomes) {
    if (o.ours.predicted < 0) {
      std::printf("%-16s -> no answer\n", o.name.c_str());
      continue;
    }
    const int off = o.ours.predicted - o.truth;
    std::printf("%-16s -> tour location %3d (%s), confidence %.2f %-9s [truth %d, %s]\n",
                o.name.c_str(), o.ours.predicted, tour_names[o.ours.predicted].c_str(),
                o.ours.confidence, o.ours.confidence >= threshold ? "LOCALISED" : "UNKNOWN",
                o.truth, std::abs(off) <= tolerance ? "ok" : "MISS");
  }
}

void PrintReport(const EvalReport& r) {
  PrintTables(r);
  PrintNegativesAndSession(r);
  const EvalSummary& s = *r.summary;
  std::printf("extract ms per query: median %.1f, p90 %.1f\n", s.extract_ms.median,
              s.extract_ms.p90);
  std::printf(
      "match stages, median ms: place %.2f, descriptor %.2f, neighbourhood %.2f, "
      "likelihood %.2f, holistic %.2f, verify %.2f\n",
      s.place_ms.median, s.descriptor_ms.median, s.neighbourhood_ms.median, s.likelihood_ms.median,
      s.holistic_ms.median, s.verify_ms.median);
}

}  // namespace sceneloc
