// sceneloc-eval: how well a map localises a folder of query images, beside the baseline.
//   sceneloc-eval --map FILE --queries DIR [--ground-truth CSV] [--tolerance N]
//                 [--baseline [--tour DIR]] [--negatives DIR] [--threads N]
//                 [--config match.yaml] [--json OUT] [--reliability PNG] [--show]
//                 [--sequence | --kidnap N [--seed S]]
// With --sequence the queries in file order are one session (sequence_filter.h): the
// table's "sceneloc" row is the session's answers, "single" the same frames answered one by
// one. --kidnap N cuts that order into N shuffled segments and reports how many frames the
// session needs to find the robot again after each jump.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "common/config/config.h"
#include "common/map/map_io.h"
#include "common/matching/sequence_filter.h"
#include "common/training/trainer.h"
#include "common/util/image_folder.h"
#include "common/util/timer.h"
#include "tools/eval/evaluation.h"
#include "tools/eval/reliability_plot.h"
#include "tools/eval/report_json.h"
#include "tools/eval/sequence_eval.h"

namespace {

namespace sl = sceneloc;
using sl::EvalSummary;
using sl::MethodSummary;
using sl::Percentiles;

int Fail(const std::string& message) {
  std::fprintf(stderr, "sceneloc-eval: %s\n", message.c_str());
  return 1;
}

struct Args {
  std::string map_path, queries_dir, truth_csv, tour_dir, negatives_dir, json_path, config_path;
  std::string reliability_png;
  int tolerance = 2;
  bool with_baseline = false;
  bool show = false;
  bool sequence = false;
  int kidnap = 0;
  uint32_t seed = 1;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
};

// The images of a folder extracted in the map's frame, one at a time (so extract times are
// those of one frame on one core); warns when their sizes differ.
sl::StatusOr<std::vector<sl::FeatureSet>> ExtractQueries(const std::vector<std::string>& paths,
                                                         const sl::Map& map,
                                                         std::vector<double>* extract_ms) {
  const auto extractor = sl::FeatureExtractor::Create(map.options.extractor);
  std::vector<sl::FeatureSet> queries;
  cv::Size first_size;
  size_t mixed_sizes = 0;
  for (size_t q = 0; q < paths.size(); ++q) {
    SCENELOC_ASSIGN_OR_RETURN(const cv::Mat image, sl::ReadImageFile(paths[q]));
    if (q == 0) first_size = image.size();
    if (image.size() != first_size) ++mixed_sizes;
    sl::Stopwatch watch;
    auto features = extractor->Extract(image, map.QueryTarget(image.cols, image.rows));
    if (!features.ok()) {
      return sl::Status(features.status().code(), paths[q] + ": " + features.status().message());
    }
    if (extract_ms != nullptr) extract_ms->push_back(watch.Milliseconds());
    queries.push_back(std::move(features).value());
  }
  if (mixed_sizes > 0) {
    std::fprintf(stderr,
                 "sceneloc-eval: warning: %zu of %zu images differ in size from the first "
                 "(%dx%d); each is brought into the map's frame\n",
                 mixed_sizes, paths.size(), first_size.width, first_size.height);
  }
  return queries;
}

// The map's tour, extracted as the map's, for the baselines.
sl::StatusOr<std::vector<sl::FeatureSet>> BaselineTour(const Args& args, const sl::Map& map) {
  const std::string dir = args.tour_dir.empty() ? map.provenance.tour_dir : args.tour_dir;
  auto paths = sl::ListImageFiles(dir);
  if (!paths.ok()) return sl::NotFound("baseline tour: " + paths.status().message());
  std::vector<std::string> names;
  for (const auto& p : *paths) names.push_back(sl::FileName(p));
  if (names != map.image_names) {
    return sl::InvalidArgument("baseline tour '" + dir + "' does not hold the map's tour images");
  }
  return sl::ExtractFolder(*paths, map.options.extractor, args.threads, nullptr);
}

// Frames of places that are not on the route: how many would be LOCALISED.
struct Negatives {
  size_t frames = 0;
  size_t accepted = 0;
  float max_confidence = 0;
};

sl::StatusOr<Negatives> RunNegatives(const Args& args, const sl::Map& map,
                                     const sl::MatchOptions& options) {
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<std::string> paths,
                            sl::ListImageFiles(args.negatives_dir));
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<sl::FeatureSet> frames,
                            ExtractQueries(paths, map, nullptr));
  Negatives n;
  sl::ThreadPool pool(args.threads);
  for (const sl::FeatureSet& f : frames) {
    SCENELOC_ASSIGN_OR_RETURN(const sl::LocaliseResult r, sl::Localise(f, map, options, &pool));
    ++n.frames;
    n.accepted += r.decision == sl::Decision::kLocalised;
    n.max_confidence = std::max(n.max_confidence, r.confidence);
  }
  return n;
}

nlohmann::json RatesJson(const MethodSummary& m) {
  nlohmann::json rates;
  for (int k = 0; k <= sl::kMaxTolerance; ++k) rates[std::to_string(k)] = m.match_rate[k];
  return rates;
}

nlohmann::json MethodJson(const MethodSummary& m) {
  return {{"match_rate", RatesJson(m)},
          {"mean_confidence", m.mean_confidence},
          {"confidence", ConfidenceJson(m.confidence)},
          {"timing_ms", {{"match", PercentilesJson(m.match_ms)}}}};
}

nlohmann::json QueryJson(const sl::QueryOutcome& o, bool with_baseline) {
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
  for (const sl::CandidateEvidence& c : o.candidates) {
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

// What a session run adds: the single-frame figures of the same frames, the filter's time,
// and for a kidnap the frames to find the robot again after each jump.
struct SessionReport {
  MethodSummary single;
  const sl::SequenceRun* run = nullptr;
  std::vector<sl::QueryOutcome> single_outcomes;
  int kidnap = 0;
};

nlohmann::json RelocalisationJson(const std::vector<int>& frames) {
  std::vector<double> values(frames.begin(), frames.end());
  const Percentiles p = sl::ComputePercentiles(values);
  return {{"per_jump", frames},
          {"median", p.median},
          {"max", frames.empty() ? 0 : *std::max_element(frames.begin(), frames.end())}};
}

nlohmann::json SessionJson(const SessionReport& r) {
  nlohmann::json j = {{"single_frame", MethodJson(r.single)},
                      {"filter_ms_median", r.run->filter_ms_median},
                      {"kidnap_segments", r.kidnap}};
  if (r.kidnap > 1) {
    j["frames_to_correct"] = RelocalisationJson(r.run->relocalisation.to_correct);
    j["frames_to_localised"] = RelocalisationJson(r.run->relocalisation.to_localised);
  }
  return j;
}

nlohmann::json ReportJson(const EvalSummary& s, const std::vector<sl::QueryOutcome>& out,
                          double load_ms, const sl::Map& map, const sl::MatchOptions& options,
                          const Negatives* negatives, const SessionReport* session) {
  nlohmann::json j = MethodJson(s.ours);
  j["queries"] = s.queries;
  j["confidence_model"] = sl::ConfidenceModelName(
      sl::SupportedModel(map, *sl::ParseConfidenceModel(options.confidence_model)));
  j["timing_ms"] = {{"extract", PercentilesJson(s.extract_ms)},
                    {"match", PercentilesJson(s.ours.match_ms)},
                    {"descriptor", PercentilesJson(s.descriptor_ms)},
                    {"neighbourhood", PercentilesJson(s.neighbourhood_ms)},
                    {"likelihood", PercentilesJson(s.likelihood_ms)},
                    {"holistic", PercentilesJson(s.holistic_ms)},
                    {"verify", PercentilesJson(s.verify_ms)},
                    {"map_load", load_ms}};
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

void PrintMethod(const char* name, const MethodSummary& m, int tolerance) {
  std::printf(
      "%-9s  %5.3f  %5.3f  %5.3f  %5.3f   %5.3f       %7.2f  %7.2f   (headline ±%d: %.3f)\n", name,
      m.match_rate[0], m.match_rate[1], m.match_rate[2], m.match_rate[3], m.mean_confidence,
      m.match_ms.median, m.match_ms.p90, tolerance, m.match_rate[tolerance]);
}

void PrintConfidence(const char* name, const MethodSummary& m) {
  const sl::ConfidenceMetrics& c = m.confidence;
  std::printf("%-9s  %6.3f  %6.2f  %5.3f (%5.3f)   %5.2f            %5.2f\n", name, c.pr_auc,
              c.recall_at_100_precision, c.ece, c.ece_floor, c.correct_accepted,
              c.accepted_precision);
}

void PrintAnswers(const std::vector<sl::QueryOutcome>& outcomes,
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

void PrintRelocalisation(const char* what, const std::vector<int>& frames) {
  if (frames.empty()) return;
  std::vector<double> values(frames.begin(), frames.end());
  std::printf("  frames to %s after a jump: median %.1f, max %d, over %zu jumps\n", what,
              sl::ComputePercentiles(values).median,
              *std::max_element(frames.begin(), frames.end()), frames.size());
}

void PrintReport(const Args& args, const EvalSummary& s, const sl::Map& map, double load_ms,
                 const sl::MatchOptions& options, const Negatives* negatives,
                 const SessionReport* session) {
  std::printf("map %s: %d locations, %d landmarks, %.1f MB in memory, loaded in %.1f ms\n",
              args.map_path.c_str(), map.num_images(), map.num_landmarks(),
              static_cast<double>(map.MemoryBytes()) / 1e6, load_ms);
  std::printf("%zu queries from %s, %d matching thread(s)\n", s.queries, args.queries_dir.c_str(),
              args.threads);
  std::printf("method     exact   ±1     ±2     ±3     confidence  match ms (median  p90)\n");
  PrintMethod("sceneloc", s.ours, args.tolerance);
  if (session != nullptr) PrintMethod("single", session->single, args.tolerance);
  if (args.with_baseline) {
    PrintMethod("baseline", s.baseline, args.tolerance);
    PrintMethod("+ransac", s.reranked, args.tolerance);
  }
  const auto model = sl::SupportedModel(map, *sl::ParseConfidenceModel(options.confidence_model));
  std::printf(
      "confidence (%s model; correct = within ±%d; accepted = confidence >= %.2f; baselines: "
      "vote or inlier share)\n",
      sl::ConfidenceModelName(model), map.options.tolerance, options.min_confidence);
  std::printf("method     PR-AUC  R@100P  ECE (floor)     correct accepted  precision\n");
  PrintConfidence("sceneloc", s.ours);
  if (session != nullptr) PrintConfidence("single", session->single);
  if (args.with_baseline) {
    PrintConfidence("baseline", s.baseline);
    PrintConfidence("+ransac", s.reranked);
  }
  if (negatives != nullptr) {
    std::printf("negatives: %zu frames from %s, %zu LOCALISED (%.1f%%), largest confidence %.2f\n",
                negatives->frames, args.negatives_dir.c_str(), negatives->accepted,
                100.0 * negatives->accepted / std::max<size_t>(1, negatives->frames),
                negatives->max_confidence);
  }
  if (session != nullptr) {
    const sl::SequenceFilter filter(map, options.sequence);
    std::printf(
        "session: the queries in %s as one session (sceneloc row; single = the same frames one "
        "by one); motion band -%d..+%d, filter %.3f ms per frame\n",
        session->kidnap > 1 ? (std::to_string(session->kidnap) + " shuffled segments").c_str()
                            : "file order",
        filter.max_backward(), filter.max_forward(), session->run->filter_ms_median);
    PrintRelocalisation("a correct answer", session->run->relocalisation.to_correct);
    PrintRelocalisation("a correct LOCALISED answer", session->run->relocalisation.to_localised);
  }
  std::printf("extract ms per query: median %.1f, p90 %.1f\n", s.extract_ms.median,
              s.extract_ms.p90);
  std::printf(
      "match stages, median ms: descriptor %.2f, neighbourhood %.2f, likelihood %.2f, "
      "holistic %.2f, verify %.2f\n",
      s.descriptor_ms.median, s.neighbourhood_ms.median, s.likelihood_ms.median,
      s.holistic_ms.median, s.verify_ms.median);
}

int Run(const Args& args) {
  sl::MatchOptions options;
  if (!args.config_path.empty()) {
    if (sl::Status s = sl::LoadMatchOptions(args.config_path, &options); !s.ok()) {
      return Fail(s.message());
    }
  }
  sl::Stopwatch load_watch;
  auto map = sl::LoadMap(args.map_path);
  if (!map.ok()) return Fail(map.status().message());
  const double load_ms = load_watch.Milliseconds();
  std::map<std::string, std::string> ground_truth;
  if (!args.truth_csv.empty()) {
    auto gt = sl::ReadGroundTruth(args.truth_csv);
    if (!gt.ok()) return Fail(gt.status().message());
    ground_truth = std::move(gt).value();
  }
  auto paths = sl::ListImageFiles(args.queries_dir);
  if (!paths.ok()) return Fail(paths.status().message());
  std::vector<double> extract_ms;
  auto queries = ExtractQueries(*paths, *map, &extract_ms);
  if (!queries.ok()) return Fail(queries.status().message());
  std::vector<std::string> names;
  for (const auto& p : *paths) names.push_back(sl::FileName(p));
  // After reading the images, so a file that is not an image is reported as such.
  auto truth = sl::ResolveTruth(names, map->image_names, ground_truth);
  if (!truth.ok()) return Fail(truth.status().message());
  std::vector<sl::QueryOutcome> outcomes(names.size());
  for (size_t q = 0; q < outcomes.size(); ++q) {
    outcomes[q].name = names[q];
    outcomes[q].truth = (*truth)[q];
    outcomes[q].extract_ms = extract_ms[q];
  }
  std::vector<sl::FeatureSet> tour;
  if (args.with_baseline) {
    auto extracted = BaselineTour(args, *map);
    if (!extracted.ok()) return Fail(extracted.status().message());
    tour = std::move(extracted).value();
  }
  const sl::Status ran = sl::RunQueries(*queries, *map, options, args.threads,
                                        args.with_baseline ? &tour : nullptr, &outcomes);
  if (!ran.ok()) return Fail(ran.message());
  std::optional<Negatives> negatives;
  if (!args.negatives_dir.empty()) {
    auto n = RunNegatives(args, *map, options);
    if (!n.ok()) return Fail("negatives: " + n.status().message());
    negatives = *n;
  }
  const sl::Judging judging{map->options.tolerance, options.min_confidence};
  std::optional<sl::SequenceRun> run;
  std::optional<SessionReport> session;
  if (args.sequence || args.kidnap > 1) {
    const std::vector<int> order = sl::KidnapOrder(outcomes.size(), args.kidnap, args.seed);
    run = sl::RunSequence(outcomes, *map, options.sequence, order);
    session = SessionReport{sl::SummariseMethod(outcomes, sl::Method::kOurs, judging), &*run,
                            outcomes, args.kidnap};
    for (size_t q = 0; q < outcomes.size(); ++q) outcomes[q].ours = run->filtered[q].ours;
  }
  const sl::Judging shown{map->options.tolerance,
                          session ? options.sequence.min_confidence : options.min_confidence};
  const EvalSummary s = sl::Summarise(outcomes, args.with_baseline, shown);
  if (args.show) PrintAnswers(outcomes, map->image_names, args.tolerance, shown.threshold);
  const SessionReport* session_report = session ? &*session : nullptr;
  PrintReport(args, s, *map, load_ms, options, negatives ? &*negatives : nullptr, session_report);
  if (!args.json_path.empty()) {
    std::ofstream out(args.json_path);
    out << ReportJson(s, outcomes, load_ms, *map, options, negatives ? &*negatives : nullptr,
                      session_report)
               .dump(2)
        << "\n";
    if (!out) return Fail("cannot write '" + args.json_path + "'");
  }
  if (!args.reliability_png.empty()) {
    std::vector<sl::ReliabilityPanel> panels = {{"sceneloc", s.ours.confidence}};
    if (args.with_baseline) panels.push_back({"baseline (vote share)", s.baseline.confidence});
    if (sl::Status w = sl::WriteReliabilityDiagram(panels, args.reliability_png); !w.ok()) {
      return Fail(w.message());
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"sceneloc-eval: match rate, confidence and timing of a map on a query folder"};
  Args args;
  app.add_option("--map", args.map_path, "map file")->required();
  app.add_option("--queries", args.queries_dir, "folder of query images")->required();
  app.add_option("--ground-truth", args.truth_csv, "CSV of query_file,tour_file rows");
  app.add_option("--tolerance", args.tolerance, "headline tolerance in frames")
      ->check(CLI::Range(0, 3));
  app.add_flag("--baseline", args.with_baseline, "also run the FLANN voting baselines");
  app.add_option("--tour", args.tour_dir, "tour folder for the baseline (default: the map's)");
  app.add_option("--negatives", args.negatives_dir,
                 "folder of frames from elsewhere: how many would be LOCALISED");
  app.add_option("--threads", args.threads, "matching threads")->check(CLI::Range(1, 256));
  app.add_option("--config", args.config_path, "matching settings (YAML), e.g. configs/match.yaml");
  app.add_option("--json", args.json_path, "write the full report as JSON");
  app.add_option("--reliability", args.reliability_png, "write a reliability diagram (PNG)");
  app.add_flag("--show", args.show, "print every query's answer");
  app.add_flag("--sequence", args.sequence,
               "the queries in file order are one session: filtered answers beside single-frame");
  app.add_option("--kidnap", args.kidnap,
                 "cut the query order into N shuffled segments (a session; frames to find the "
                 "robot again after each jump)")
      ->check(CLI::Range(2, 100000));
  app.add_option("--seed", args.seed, "shuffle seed of --kidnap");
  CLI11_PARSE(app, argc, argv);
  return Run(args);
}
