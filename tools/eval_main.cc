// sceneloc-eval: how well a map localises a folder of query images, beside the baseline.
//   sceneloc-eval --map FILE --queries DIR [--ground-truth CSV] [--tolerance N]
//                 [--baseline [--tour DIR]] [--threads N] [--config match.yaml] [--json OUT]
#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "common/config/config.h"
#include "common/map/map_io.h"
#include "common/training/trainer.h"
#include "common/util/image_folder.h"
#include "common/util/timer.h"
#include "tools/eval/evaluation.h"

namespace {

using sceneloc::EvalSummary;
using sceneloc::MethodSummary;
using sceneloc::Percentiles;

int Fail(const std::string& message) {
  std::fprintf(stderr, "sceneloc-eval: %s\n", message.c_str());
  return 1;
}

nlohmann::json RatesJson(const MethodSummary& m) {
  nlohmann::json rates;
  for (int k = 0; k <= sceneloc::kMaxTolerance; ++k) rates[std::to_string(k)] = m.match_rate[k];
  return rates;
}

nlohmann::json PercentilesJson(const Percentiles& p) {
  return {{"median", p.median}, {"p90", p.p90}, {"p99", p.p99}};
}

nlohmann::json ReportJson(const EvalSummary& s, const std::vector<sceneloc::QueryOutcome>& out,
                          double load_ms, size_t map_memory_bytes) {
  nlohmann::json j;
  j["queries"] = s.queries;
  j["match_rate"] = RatesJson(s.ours);
  j["mean_confidence"] = s.ours.mean_confidence;
  j["timing_ms"] = {{"extract", PercentilesJson(s.extract_ms)},
                    {"match", PercentilesJson(s.ours.match_ms)},
                    {"descriptor", PercentilesJson(s.descriptor_ms)},
                    {"neighbourhood", PercentilesJson(s.neighbourhood_ms)},
                    {"likelihood", PercentilesJson(s.likelihood_ms)},
                    {"holistic", PercentilesJson(s.holistic_ms)},
                    {"verify", PercentilesJson(s.verify_ms)},
                    {"map_load", load_ms}};
  j["map_memory_bytes"] = map_memory_bytes;
  if (s.has_baseline) {
    j["baseline"] = {{"match_rate", RatesJson(s.baseline)},
                     {"mean_confidence", s.baseline.mean_confidence},
                     {"timing_ms", {{"match", PercentilesJson(s.baseline.match_ms)}}}};
    j["baseline_reranked"] = {{"match_rate", RatesJson(s.reranked)},
                              {"mean_confidence", s.reranked.mean_confidence},
                              {"timing_ms", {{"match", PercentilesJson(s.reranked.match_ms)}}}};
  }
  j["per_query"] = nlohmann::json::array();
  for (const auto& o : out) {
    nlohmann::json q = {{"query", o.name},
                        {"truth", o.truth},
                        {"predicted", o.ours.predicted},
                        {"confidence", o.ours.confidence},
                        {"extract_ms", o.extract_ms},
                        {"match_ms", o.ours.ms}};
    if (s.has_baseline) {
      q["baseline_predicted"] = o.baseline.predicted;
      q["baseline_confidence"] = o.baseline.confidence;
      q["baseline_reranked_predicted"] = o.reranked.predicted;
      q["baseline_reranked_confidence"] = o.reranked.confidence;
    }
    q["keypoints"] = o.keypoints;
    q["descriptor_matches"] = o.descriptor_matches;
    q["location_scores"] = o.location_scores;
    q["candidates"] = nlohmann::json::array();
    for (const sceneloc::CandidateEvidence& c : o.candidates) {
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
    j["per_query"].push_back(q);
  }
  return j;
}

void PrintMethod(const char* name, const MethodSummary& m, int tolerance) {
  std::printf(
      "%-9s  %5.3f  %5.3f  %5.3f  %5.3f   %5.3f       %7.2f  %7.2f   (headline ±%d: %.3f)\n", name,
      m.match_rate[0], m.match_rate[1], m.match_rate[2], m.match_rate[3], m.mean_confidence,
      m.match_ms.median, m.match_ms.p90, tolerance, m.match_rate[tolerance]);
}

void PrintAnswers(const std::vector<sceneloc::QueryOutcome>& outcomes,
                  const std::vector<std::string>& tour_names, int tolerance) {
  for (const auto& o : outcomes) {
    if (o.ours.predicted < 0) {
      std::printf("%-16s -> no answer (no landmark matched)\n", o.name.c_str());
      continue;
    }
    const int off = o.ours.predicted - o.truth;
    std::printf("%-16s -> tour location %3d (%s), confidence %.2f  [truth %d, %s]\n",
                o.name.c_str(), o.ours.predicted, tour_names[o.ours.predicted].c_str(),
                o.ours.confidence, o.truth, std::abs(off) <= tolerance ? "ok" : "MISS");
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"sceneloc-eval: match rate, confidence and timing of a map on a query folder"};
  std::string map_path, queries_dir, truth_csv, tour_dir, json_path, config_path;
  int tolerance = 2;
  bool with_baseline = false;
  bool show = false;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  app.add_option("--map", map_path, "map file")->required();
  app.add_option("--queries", queries_dir, "folder of query images")->required();
  app.add_option("--ground-truth", truth_csv, "CSV of query_file,tour_file rows");
  app.add_option("--tolerance", tolerance, "headline tolerance in frames")->check(CLI::Range(0, 3));
  app.add_flag("--baseline", with_baseline, "also run the FLANN voting baseline");
  app.add_option("--tour", tour_dir, "tour folder for the baseline (default: the map's)");
  app.add_option("--threads", threads, "matching threads")->check(CLI::Range(1, 256));
  app.add_option("--config", config_path, "matching settings (YAML), e.g. configs/match.yaml");
  app.add_option("--json", json_path, "write the full report as JSON");
  app.add_flag("--show", show, "print every query's answer");
  CLI11_PARSE(app, argc, argv);

  sceneloc::MatchOptions options;
  if (!config_path.empty()) {
    const sceneloc::Status s = sceneloc::LoadMatchOptions(config_path, &options);
    if (!s.ok()) return Fail(s.message());
  }
  sceneloc::Stopwatch load_watch;
  auto map = sceneloc::LoadMap(map_path);
  if (!map.ok()) return Fail(map.status().message());
  const double load_ms = load_watch.Milliseconds();

  std::map<std::string, std::string> ground_truth;
  if (!truth_csv.empty()) {
    auto gt = sceneloc::ReadGroundTruth(truth_csv);
    if (!gt.ok()) return Fail(gt.status().message());
    ground_truth = std::move(gt).value();
  }
  auto paths = sceneloc::ListImageFiles(queries_dir);
  if (!paths.ok()) return Fail(paths.status().message());
  std::vector<std::string> names;
  for (const auto& p : *paths) names.push_back(sceneloc::FileName(p));

  // Queries are extracted one at a time so extract times are those of one frame on one core.
  const auto extractor = sceneloc::FeatureExtractor::Create(map->options.extractor);
  std::vector<sceneloc::FeatureSet> queries;
  std::vector<sceneloc::QueryOutcome> outcomes(paths->size());
  cv::Size first_size;
  size_t mixed_sizes = 0;
  for (size_t q = 0; q < paths->size(); ++q) {
    auto image = sceneloc::ReadImageFile((*paths)[q]);
    if (!image.ok()) return Fail(image.status().message());
    if (q == 0) first_size = image->size();
    if (image->size() != first_size) ++mixed_sizes;
    sceneloc::Stopwatch watch;
    auto features = extractor->Extract(*image, map->QueryTarget(image->cols, image->rows));
    if (!features.ok()) return Fail((*paths)[q] + ": " + features.status().message());
    outcomes[q].extract_ms = watch.Milliseconds();
    outcomes[q].name = names[q];
    queries.push_back(std::move(features).value());
  }
  if (mixed_sizes > 0) {
    std::fprintf(stderr,
                 "sceneloc-eval: warning: %zu of %zu query images differ in size from the first "
                 "(%dx%d); each is brought into the map's frame\n",
                 mixed_sizes, paths->size(), first_size.width, first_size.height);
  }
  // After reading the images, so a file that is not an image is reported as such.
  auto truth = sceneloc::ResolveTruth(names, map->image_names, ground_truth);
  if (!truth.ok()) return Fail(truth.status().message());
  for (size_t q = 0; q < outcomes.size(); ++q) outcomes[q].truth = (*truth)[q];

  std::vector<sceneloc::FeatureSet> tour;
  if (with_baseline) {
    if (tour_dir.empty()) tour_dir = map->provenance.tour_dir;
    auto tour_paths = sceneloc::ListImageFiles(tour_dir);
    if (!tour_paths.ok()) return Fail("baseline tour: " + tour_paths.status().message());
    std::vector<std::string> tour_names;
    for (const auto& p : *tour_paths) tour_names.push_back(sceneloc::FileName(p));
    if (tour_names != map->image_names) {
      return Fail("baseline tour '" + tour_dir + "' does not hold the map's tour images");
    }
    auto extracted = sceneloc::ExtractFolder(*tour_paths, map->options.extractor, threads, nullptr);
    if (!extracted.ok()) return Fail(extracted.status().message());
    tour = std::move(extracted).value();
  }
  const sceneloc::Status ran = sceneloc::RunQueries(queries, *map, options, threads,
                                                    with_baseline ? &tour : nullptr, &outcomes);
  if (!ran.ok()) return Fail(ran.message());
  const EvalSummary s = sceneloc::Summarise(outcomes, with_baseline);

  if (show) PrintAnswers(outcomes, map->image_names, tolerance);
  std::printf("map %s: %d locations, %d landmarks, %.1f MB in memory, loaded in %.1f ms\n",
              map_path.c_str(), map->num_images(), map->num_landmarks(),
              static_cast<double>(map->MemoryBytes()) / 1e6, load_ms);
  std::printf("%zu queries from %s, %d matching thread(s)\n", s.queries, queries_dir.c_str(),
              threads);
  std::printf("method     exact   ±1     ±2     ±3     confidence  match ms (median  p90)\n");
  PrintMethod("sceneloc", s.ours, tolerance);
  if (with_baseline) {
    PrintMethod("baseline", s.baseline, tolerance);
    PrintMethod("+ransac", s.reranked, tolerance);
  }
  std::printf("extract ms per query: median %.1f, p90 %.1f\n", s.extract_ms.median,
              s.extract_ms.p90);
  std::printf(
      "match stages, median ms: descriptor %.2f, neighbourhood %.2f, likelihood %.2f, "
      "holistic %.2f, verify %.2f\n",
      s.descriptor_ms.median, s.neighbourhood_ms.median, s.likelihood_ms.median,
      s.holistic_ms.median, s.verify_ms.median);
  if (!json_path.empty()) {
    std::ofstream out(json_path);
    out << ReportJson(s, outcomes, load_ms, map->MemoryBytes()).dump(2) << "\n";
    if (!out) return Fail("cannot write '" + json_path + "'");
  }
  return 0;
}
