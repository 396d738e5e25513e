// sceneloc-eval: how well a map localises a folder of query images, beside the baseline.
//   sceneloc-eval --map FILE --queries DIR [--ground-truth CSV] [--tolerance N]
//                 [--baseline [--tour DIR]] [--negatives DIR] [--threads N]
//                 [--config match.yaml] [--json OUT] [--reliability PNG] [--show]
//                 [--sequence | --kidnap N [--seed S]] [--reverse]
// With --sequence the queries in file order are one session (sequence_filter.h): the
// table's "sceneloc" row is the session's answers, "single" the same frames answered one by
// one. --kidnap N cuts that order into N shuffled segments and reports how many frames the
// session needs to find the robot again after each jump. --reverse runs the session over
// the queries in reverse file order: a robot backing up the route.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <thread>

#include "common/config/config.h"
#include "common/map/map_io.h"
#include "common/matching/sequence_filter.h"
#include "common/training/trainer.h"
#include "common/util/image_folder.h"
#include "common/util/timer.h"
#include "common/util/version.h"
#include "tools/eval/eval_report.h"
#include "tools/eval/evaluation.h"
#include "tools/eval/reliability_plot.h"
#include "tools/eval/sequence_eval.h"

namespace {

namespace sl = sceneloc;
using sl::EvalSummary;
using sl::Negatives;
using sl::SessionReport;

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
  bool reverse = false;
  double camera_scale = 0;  // the query camera as a client would state it; 0 = not stated
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
};

// A stated camera scale's range; CLI::Range alone lets NaN through.
CLI::Validator CameraScaleValidator() {
  return CLI::Validator(
      [](std::string& text) {
        double x = 0;
        const bool ok = CLI::detail::lexical_cast(text, x) && sl::CheckCameraScale(x).ok();
        return ok ? std::string() : "must be a number in " + sl::CameraScaleRange();
      },
      "in " + sl::CameraScaleRange());
}

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
  if (names != map.PlaceNames()) {
    return sl::InvalidArgument("baseline tour '" + dir + "' does not hold the map's tour images");
  }
  return sl::ExtractFolder(*paths, map.options.extractor, args.threads, nullptr);
}

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

// The matching settings: the defaults, or --config.
sl::Status LoadOptions(const Args& args, sl::MatchOptions* options) {
  if (args.config_path.empty()) return sl::Status::Ok();
  return sl::LoadMatchOptions(args.config_path, options);
}

// The queries, extracted in the map's frame, and one outcome per query holding its name,
// true location and extraction time.
struct Queries {
  std::vector<sl::FeatureSet> features;
  std::vector<sl::QueryOutcome> outcomes;
};

sl::StatusOr<Queries> PrepareQueries(const Args& args, const sl::Map& map) {
  std::map<std::string, std::string> ground_truth;
  if (!args.truth_csv.empty()) {
    SCENELOC_ASSIGN_OR_RETURN(ground_truth, sl::ReadGroundTruth(args.truth_csv));
  }
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<std::string> paths,
                            sl::ListImageFiles(args.queries_dir));
  std::vector<double> extract_ms;
  Queries queries;
  SCENELOC_ASSIGN_OR_RETURN(queries.features, ExtractQueries(paths, map, &extract_ms));
  std::vector<std::string> names;
  for (const auto& p : paths) names.push_back(sl::FileName(p));
  // After reading the images, so a file that is not an image is reported as such.
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<int> truth,
                            sl::ResolveTruth(names, map.PlaceNames(), ground_truth));
  queries.outcomes.resize(names.size());
  for (size_t q = 0; q < names.size(); ++q) {
    queries.outcomes[q].name = names[q];
    queries.outcomes[q].truth = truth[q];
    queries.outcomes[q].extract_ms = extract_ms[q];
  }
  return queries;
}

// Localises the queries with ours, and with the baselines when asked.
sl::Status RunMethods(const Args& args, const sl::Map& map, const sl::MatchOptions& options,
                      Queries* queries) {
  std::vector<sl::FeatureSet> tour;
  if (args.with_baseline) {
    SCENELOC_ASSIGN_OR_RETURN(tour, BaselineTour(args, map));
  }
  return sl::RunQueries(queries->features, map, options, args.threads,
                        args.with_baseline ? &tour : nullptr, &queries->outcomes);
}

// With --sequence or --kidnap: the queries as one session (in `*run`). The report keeps
// the single-frame figures; the outcomes' `ours` become the session's answers.
std::optional<SessionReport> RunSession(const Args& args, const sl::Map& map,
                                        const sl::MatchOptions& options,
                                        std::optional<sl::SequenceRun>* run,
                                        std::vector<sl::QueryOutcome>* outcomes) {
  if (!args.sequence && args.kidnap <= 1 && !args.reverse) return std::nullopt;
  const sl::Judging judging{map.options.tolerance, options.min_confidence};
  const std::vector<int> order =
      sl::KidnapOrder(outcomes->size(), args.kidnap, args.seed, args.reverse);
  *run = sl::RunSequence(
      *outcomes, map, options, order,
      args.camera_scale > 0 ? std::optional<double>(options.camera_log_scale) : std::nullopt);
  SessionReport session{sl::SummariseMethod(*outcomes, sl::Method::kOurs, judging),
                        sl::SummariseMethod((*run)->in_session, sl::Method::kOurs, judging),
                        &**run,
                        *outcomes,
                        args.kidnap,
                        args.reverse};
  for (size_t q = 0; q < outcomes->size(); ++q) (*outcomes)[q].ours = (*run)->filtered[q].ours;
  return session;
}

// The run as the report's heading names it; the caller adds the figures.
sl::EvalReport ReportHeading(const Args& args, double load_ms) {
  sl::EvalReport report;
  report.map_path = args.map_path;
  report.queries_dir = args.queries_dir;
  report.negatives_dir = args.negatives_dir;
  report.threads = args.threads;
  report.tolerance = args.tolerance;
  report.with_baseline = args.with_baseline;
  report.load_ms = load_ms;
  return report;
}

// The --json and --reliability files, when asked for.
sl::Status WriteOutputs(const Args& args, const sl::EvalReport& report) {
  if (!args.json_path.empty()) {
    std::ofstream out(args.json_path);
    out << sl::ReportJson(report).dump(2) << "\n";
    if (!out) return sl::IoError("cannot write '" + args.json_path + "'");
  }
  if (args.reliability_png.empty()) return sl::Status::Ok();
  std::vector<sl::ReliabilityPanel> panels = {{"sceneloc", report.summary->ours.confidence}};
  if (args.with_baseline) {
    panels.push_back({"baseline (vote share)", report.summary->baseline.confidence});
  }
  return sl::WriteReliabilityDiagram(panels, args.reliability_png);
}

int Run(const Args& args) {
  sl::MatchOptions options;
  if (sl::Status s = LoadOptions(args, &options); !s.ok()) return Fail(s.message());
  if (args.camera_scale > 0) {
    options.camera_log_scale = std::log(args.camera_scale);
    options.camera_known = true;
  }
  sl::Stopwatch load_watch;
  auto map = sl::LoadMap(args.map_path);
  if (!map.ok()) return Fail(map.status().message());
  const double load_ms = load_watch.Milliseconds();
  auto queries = PrepareQueries(args, *map);
  if (!queries.ok()) return Fail(queries.status().message());
  if (sl::Status ran = RunMethods(args, *map, options, &*queries); !ran.ok()) {
    return Fail(ran.message());
  }
  std::optional<Negatives> negatives;
  if (!args.negatives_dir.empty()) {
    auto n = RunNegatives(args, *map, options);
    if (!n.ok()) return Fail("negatives: " + n.status().message());
    negatives = *n;
  }
  std::vector<sl::QueryOutcome>& outcomes = queries->outcomes;
  std::optional<sl::SequenceRun> run;
  const std::optional<SessionReport> session = RunSession(args, *map, options, &run, &outcomes);
  const sl::Judging shown{map->options.tolerance,
                          session ? options.sequence.min_confidence : options.min_confidence};
  const EvalSummary s = sl::Summarise(outcomes, args.with_baseline, shown);
  if (args.show) sl::PrintAnswers(outcomes, map->PlaceNames(), args.tolerance, shown.threshold);
  sl::EvalReport report = ReportHeading(args, load_ms);
  report.summary = &s;
  report.outcomes = &outcomes;
  report.map = &*map;
  report.options = &options;
  report.negatives = negatives ? &*negatives : nullptr;
  report.session = session ? &*session : nullptr;
  sl::PrintReport(report);
  const sl::Status written = WriteOutputs(args, report);
  return written.ok() ? 0 : Fail(written.message());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"sceneloc-eval: match rate, confidence and timing of a map on a query folder"};
  app.set_version_flag("--version", std::string(sceneloc::Version()));
  Args args;
  bool print_config = false;
  app.add_flag("--print-config", print_config,
               "print the matching settings in effect (defaults, or --config) as a documented "
               "settings file, and exit");
  app.add_option("--map", args.map_path, "map file (required)");
  app.add_option("--queries", args.queries_dir, "folder of query images (required)");
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
  app.add_flag("--reverse", args.reverse,
               "the session walks the queries in reverse file order (a robot backing up the "
               "route); implies --sequence");
  app.add_option("--camera-scale", args.camera_scale,
                 "the query camera as a client states it (LocaliseRequest.camera_scale): focal "
                 "length over image width against the tour camera's (default: not stated: the one "
                 "the frame's shape implies, the tour's for the tour's shape; in a session what "
                 "it learns)")
      ->check(CameraScaleValidator());
  CLI11_PARSE(app, argc, argv);
  if (print_config) {
    sl::MatchOptions options;
    if (const sl::Status s = LoadOptions(args, &options); !s.ok()) {
      std::fprintf(stderr, "sceneloc-eval: %s\n", s.message().c_str());
      return 2;
    }
    std::fputs(sl::DocumentedMatchSettings(options).c_str(), stdout);
    return 0;
  }
  if (args.map_path.empty() || args.queries_dir.empty()) {
    std::fprintf(stderr, "sceneloc-eval: --map and --queries are required (see --help)\n");
    return 2;
  }
  return Run(args);
}
