// sceneloc-accuracy: the accuracy suite (tools/eval/accuracy_suite.h) in one run. Every
// development set, four methods on the same features (and ours as a session), one table on
// stdout, and
//   OUT/accuracy.json   every figure, per set and method, with the settings and machine
//   OUT/accuracy.csv    one row per set and method
// (scripts/accuracy.sh adds OUT/accuracy.png). Run from the repository root:
//   sceneloc-accuracy --data ../shared/data --out accuracy-out [--sets gp_day,corridor]
// `--sets swapped` runs the three sets with tour and queries swapped instead (SwappedSuite):
// maps nothing was tuned on. `--distractors DIR` runs every set on a map padded to
// --distractor-locations (tools/eval/distractor_suite.h): the route a small part of a campus.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "common/config/config.h"
#include "common/util/image_folder.h"
#include "common/util/progress_printer.h"
#include "common/util/timer.h"
#include "common/util/version.h"
#include "tools/eval/accuracy_suite.h"
#include "tools/eval/distractor_suite.h"
#include "tools/eval/leave_one_out.h"
#include "tools/eval/reliability_plot.h"
#include "tools/eval/report_json.h"

namespace {

namespace sl = sceneloc;

int Fail(const std::string& message) {
  std::fprintf(stderr, "sceneloc-accuracy: %s\n", message.c_str());
  return 1;
}

struct Row {
  std::string method;
  const sl::MethodSummary* summary;
};

// The methods a set ran: ours, and the paper's and the baselines' unless on distractors.
std::vector<Row> Rows(const sl::SetResult& r) {
  std::vector<Row> rows = {
      {"sceneloc", &r.summary.ours}, {"in session", &r.in_session}, {"session", &r.session}};
  if (r.comparisons) {
    rows.insert(rows.end(), {{"paper", &r.paper},
                             {"baseline", &r.summary.baseline},
                             {"baseline+ransac", &r.summary.reranked}});
  }
  return rows;
}

// Each verified candidate as [location, holistic_z, inliers, log_scale, holistic]: what its
// fused score is computed from (common/matching/evidence.h).
nlohmann::json CandidatesJson(const std::vector<sl::CandidateEvidence>& candidates) {
  nlohmann::json out = nlohmann::json::array();
  for (const sl::CandidateEvidence& c : candidates) {
    out.push_back({c.location, c.holistic_z, c.inliers, c.log_scale, c.holistic});
  }
  return out;
}

nlohmann::json QueriesJson(const sl::SetResult& r) {
  nlohmann::json out = nlohmann::json::array();
  for (size_t q = 0; q < r.outcomes.size(); ++q) {
    const sl::QueryOutcome& o = r.outcomes[q];
    nlohmann::json query = {
        {"query", o.name},
        {"truth", o.truth},
        {"sceneloc", {o.ours.predicted, o.ours.confidence}},
        {"in session", {r.in_session_outcomes[q].predicted, r.in_session_outcomes[q].confidence}},
        {"session", {r.session_outcomes[q].predicted, r.session_outcomes[q].confidence}},
        // What our confidence is made of (common/matching/confidence.h): every
        // location's fused evidence, P(in the map), the verified candidates (whose
        // scores the average over cameras re-reads) and the camera they were read with
        // and its doubt, so that its constants can be re-fitted offline
        // (scripts/fit_confidence.py).
        {"evidence",
         {{"in_map", o.in_map},
          {"scores", o.location_scores},
          {"candidates", CandidatesJson(o.candidates)},
          {"camera", {o.camera_log_scale, o.camera_log_doubt}}}}};
    if (r.comparisons) {
      query["paper"] = {r.paper_outcomes[q].predicted, r.paper_outcomes[q].confidence};
      query["baseline"] = {o.baseline.predicted, o.baseline.confidence};
      query["baseline+ransac"] = {o.reranked.predicted, o.reranked.confidence};
    }
    out.push_back(std::move(query));
  }
  return out;
}

// The session on every walk (sequence_eval.h StandardWalks) and the kidnapped robot.
nlohmann::json WalksJson(const sl::SetResult& r) {
  nlohmann::json walks = nlohmann::json::object();
  for (const sl::WalkSummary& w : r.walks) {
    walks[w.name] = {{"steps", w.steps},
                     {"rate", w.rate},
                     {"ece", w.ece},
                     {"ece_floor", w.ece_floor},
                     {"localised", w.localised},
                     {"localised_precision", w.localised_precision}};
  }
  return {{"walks", walks},
          {"kidnap",
           {{"segments", r.kidnap.segments},
            {"seeds", r.kidnap.seeds},
            {"jumps", r.kidnap.jumps},
            {"frames_to_correct_median", r.kidnap.median},
            {"frames_to_correct_worst", r.kidnap.worst}}}};
}

// The command that renders a generated set ("" for a set of real folders).
std::string GeneratedBy(const sl::SuiteSet& set) {
  if (!set.generated) return "";
  const sl::TourOptions& o = *set.generated;
  return "sceneloc-gentour --locations " + std::to_string(o.num_locations) + " --repeat-blocks " +
         std::to_string(o.repeat_blocks) + " --seed " + std::to_string(o.seed);
}

nlohmann::json SetJson(const sl::SetResult& r) {
  nlohmann::json methods;
  for (const Row& row : Rows(r)) methods[row.method] = sl::MethodJson(*row.summary);
  return {{"name", r.set.name},
          {"description", r.set.description},
          {"tour", r.set.tour_dir},
          {"generated", GeneratedBy(r.set)},
          {"queries_dir", r.set.queries_dir},
          {"change", sl::QueryChangeName(r.set.change)},
          {"locations", r.locations},
          {"queries", r.outcomes.size()},
          {"landmarks", r.landmarks},
          {"train_s", r.train_seconds},
          {"extract_ms_median", r.summary.extract_ms.median},
          {"methods", methods},
          {"negatives",
           {{"frames", r.negatives},
            {"accepted", r.negatives_accepted},
            {"max_confidence", r.negatives_max_confidence}}},
          {"sessions", WalksJson(r)},
          {"per_query", QueriesJson(r)}};
}

// The session's ±tolerance rate on every walk, one column per set, then the kidnapped
// robot's frames to a correct answer (median / worst).
void PrintWalks(const std::vector<sl::SetResult>& results) {
  if (results.empty() || results[0].walks.empty()) return;
  std::printf("\nsessions on walks (answers within the tolerance; LOCALISED precision)\n%-16s",
              "walk");
  for (const sl::SetResult& r : results) std::printf(" %15s", r.set.name.c_str());
  std::printf("\n");
  for (size_t w = 0; w < results[0].walks.size(); ++w) {
    std::printf("%-16s", results[0].walks[w].name.c_str());
    for (const sl::SetResult& r : results) {
      std::printf("   %5.3f (%5.3f)", r.walks[w].rate, r.walks[w].localised_precision);
    }
    std::printf("\n");
  }
  std::printf("%-16s", "kidnap med/worst");
  for (const sl::SetResult& r : results) {
    std::printf(" %15s", (std::to_string(static_cast<int>(r.kidnap.median)) + " / " +
                          std::to_string(r.kidnap.worst))
                             .c_str());
  }
  std::printf("\n");
  std::fflush(stdout);
}

void PrintHeader() {
  std::printf("%-16s %5s  %-16s %6s %6s %6s %6s  %9s\n", "set", "n", "method", "exact", "±1", "±2",
              "±3", "match ms");
}

void PrintSet(const sl::SetResult& r) {
  bool first = true;
  for (const Row& row : Rows(r)) {
    const sl::MethodSummary& m = *row.summary;
    std::printf(
        "%-16s %5s  %-16s %6.3f %6.3f %6.3f %6.3f  %9.1f\n", first ? r.set.name.c_str() : "",
        first ? std::to_string(r.outcomes.size()).c_str() : "", row.method.c_str(), m.match_rate[0],
        m.match_rate[1], m.match_rate[2], m.match_rate[3], m.match_ms.median);
    first = false;
  }
  std::fflush(stdout);
}

// Our settings with one ablation variant's overrides ("@paper": the paper's settings).
sl::StatusOr<sl::SuiteSettings> VariantSettings(const sl::SuiteSettings& base,
                                                const sl::AblationVariant& v) {
  sl::SuiteSettings s = base;
  if (v.train_yaml == "@paper") {
    s.train = base.paper_train;
    s.train.extractor = base.train.extractor;
  } else {
    SCENELOC_RETURN_IF_ERROR(sl::ParseTrainOptions(v.train_yaml, v.name, &s.train));
  }
  if (v.match_yaml == "@paper") {
    s.match = base.paper_match;
  } else {
    SCENELOC_RETURN_IF_ERROR(sl::ParseMatchOptions(v.match_yaml, v.name, &s.match));
  }
  return s;
}

// Every variant on every set: one line per variant with ±2 / ±3 per set, and
// OUT/ablation.csv.
int RunAblation(const std::vector<sl::SuiteSet>& sets, const sl::SuiteSettings& settings,
                const std::vector<std::string>& only, const sl::SuiteContext& context,
                const std::string& out_dir) {
  std::ofstream csv(out_dir + "/ablation.csv");
  if (!csv) return Fail("cannot write to '" + out_dir + "'");
  csv << "variant,set,queries,landmarks,train_s,rate0,rate1,rate2,rate3,match_ms_median\n";
  std::printf("%-22s", "±2 / ±3");
  for (const sl::SuiteSet& set : sets) std::printf(" %15s", set.name.c_str());
  std::printf("\n");
  for (const sl::AblationVariant& v : sl::AblationVariants()) {
    if (!only.empty() && std::find(only.begin(), only.end(), v.name) == only.end()) continue;
    auto s = VariantSettings(settings, v);
    if (!s.ok()) return Fail(s.status().message());
    std::printf("%-22s", v.name.c_str());
    for (const sl::SuiteSet& set : sets) {
      auto data = sl::LoadSet(set, s->train.extractor, context);
      if (!data.ok()) return Fail(set.name + ": " + data.status().message());
      auto r = sl::RunVariant(*data, s->train, s->match, context);
      if (!r.ok()) return Fail(v.name + " on " + set.name + ": " + r.status().message());
      const sl::MethodSummary& m = r->summary;
      std::printf("     %.2f / %.2f", m.match_rate[2], m.match_rate[3]);
      std::fflush(stdout);
      csv << v.name << ',' << set.name << ',' << r->outcomes.size() << ',' << r->landmarks << ','
          << r->train_seconds << ',' << m.match_rate[0] << ',' << m.match_rate[1] << ','
          << m.match_rate[2] << ',' << m.match_rate[3] << ',' << m.match_ms.median << '\n'
          << std::flush;
    }
    std::printf("\n");
  }
  return 0;
}

// Confidence rows of ours and the baselines' (vote share) for one summary.
void PrintConfidenceRows(const std::string& label, const std::vector<Row>& rows,
                         const std::string& negatives) {
  bool first = true;
  for (const Row& row : rows) {
    if (row.method == "paper") continue;
    const sl::ConfidenceMetrics& c = row.summary->confidence;
    std::printf("%-16s %-16s %7.3f %7.2f %6.3f (%.3f) %9.2f %9.2f %12s\n",
                first ? label.c_str() : "", row.method.c_str(), c.pr_auc, c.recall_at_100_precision,
                c.ece, c.ece_floor, c.correct_accepted, c.accepted_precision,
                first ? negatives.c_str() : "");
    first = false;
  }
}

struct PooledSummaries {
  sl::EvalSummary real;  // the sets whose query frames are used as they are
  sl::EvalSummary all;
};

PooledSummaries PoolSets(const std::vector<sl::SetResult>& results, const sl::Judging& judging) {
  return {sl::PooledSummary(results, /*unchanged_only=*/true, judging),
          sl::PooledSummary(results, /*unchanged_only=*/false, judging)};
}

std::vector<Row> SummaryRows(const sl::EvalSummary& s, bool comparisons) {
  if (!comparisons) return {{"sceneloc", &s.ours}};
  return {{"sceneloc", &s.ours}, {"baseline", &s.baseline}, {"baseline+ransac", &s.reranked}};
}

// Whether the sets ran the paper's map and the baselines (all do, or none: distractors).
bool Comparisons(const std::vector<sl::SetResult>& results) {
  return results.empty() || results[0].comparisons;
}

// The confidence of every set: ours and the baselines' (vote share), with our out-of-map
// frames; then the sets pooled.
void PrintConfidenceTable(const std::vector<sl::SetResult>& results, const PooledSummaries& pooled,
                          double threshold) {
  std::printf(
      "\nconfidence: correct = within the map's tolerance; accepted = sceneloc's confidence >= "
      "%.2f; baselines score by vote (or inlier) share\n",
      threshold);
  std::printf("%-16s %-16s %7s %7s %14s %9s %9s %12s\n", "set", "method", "PR-AUC", "R@100P",
              "ECE (floor)", "accepted", "precision", "out-of-map");
  for (const sl::SetResult& r : results) {
    std::string negatives = "";
    if (r.negatives > 0) {
      negatives = std::to_string(r.negatives_accepted) + "/" + std::to_string(r.negatives);
    }
    PrintConfidenceRows(r.set.name, Rows(r), negatives);
  }
  PrintConfidenceRows("pooled: real " + std::to_string(pooled.real.queries),
                      SummaryRows(pooled.real, Comparisons(results)), "");
  PrintConfidenceRows("pooled: all " + std::to_string(pooled.all.queries),
                      SummaryRows(pooled.all, Comparisons(results)), "");
}

std::string Hostname() {
  char name[256] = {0};
  gethostname(name, sizeof(name) - 1);
  return name;
}

// The command line.
struct Args {
  std::string data_dir = "../shared/data", out_dir = "accuracy-out", cache_dir;
  std::string train_config = "configs/train.yaml", match_config = "configs/match.yaml";
  std::string paper_train = "configs/paper-train.yaml", paper_match = "configs/paper-match.yaml";
  std::vector<std::string> only, variants;
  bool ablation = false;
  int tour_limit = 0, query_limit = 0;
  std::string distractors_dir;  // "" = each set's own map (distractor_suite.h)
  sl::DistractorOptions distractors;
  sl::SuiteContext context;
};

void AddOptions(CLI::App* app, Args* a) {
  a->context.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  app->add_option("--data", a->data_dir, "the development data (gardens_point/, corridor/)")
      ->capture_default_str();
  app->add_option("--out", a->out_dir, "folder for accuracy.json and accuracy.csv")
      ->capture_default_str();
  app->add_option("--cache", a->cache_dir, "features and generated variants (default OUT/cache)");
  app->add_option(
         "--sets", a->only,
         "run only these sets (comma-separated names; \"swapped\" adds the three sets with tour "
         "and queries swapped, which are not run by default)")
      ->delimiter(',');
  app->add_option("--tour-limit", a->tour_limit, "use the first N tour images of every set");
  app->add_option("--query-limit", a->query_limit, "use the first N queries of every set");
  app->add_option("--config", a->train_config, "our training settings")->capture_default_str();
  app->add_option("--match-config", a->match_config, "our matching settings")
      ->capture_default_str();
  app->add_option("--paper-config", a->paper_train, "the paper's training settings")
      ->capture_default_str();
  app->add_option("--paper-match-config", a->paper_match, "the paper's matching settings")
      ->capture_default_str();
  app->add_option("--threads", a->context.threads, "threads")->check(CLI::Range(1, 256));
  app->add_flag("--ablation", a->ablation,
                "run the ablation instead: every variant on every set (OUT/ablation.csv)");
  app->add_option("--variants", a->variants, "with --ablation: only these variants")
      ->delimiter(',');
  app->add_option("--distractors", a->distractors_dir,
                  "pad every set's map to --distractor-locations with the other data set's "
                  "frames, then these images in name order (e.g. sceneloc-gentour --passes "
                  "tour); ours only");
  app->add_option("--distractor-locations", a->distractors.locations,
                  "with --distractors: every padded map's size")
      ->capture_default_str()
      ->check(CLI::Range(2, 10000000));
  app->add_option("--offroute", a->distractors.offroute_dir,
                  "with --distractors: frames of no map, counted when LOCALISED");
}

// Ours and the paper's settings, from their four files (all are read; the first error
// is reported).
sl::Status LoadSettings(const Args& a, sl::SuiteSettings* settings) {
  for (const auto& [path, status] :
       {std::pair{a.train_config, sl::LoadTrainOptions(a.train_config, &settings->train)},
        std::pair{a.match_config, sl::LoadMatchOptions(a.match_config, &settings->match)},
        std::pair{a.paper_train, sl::LoadTrainOptions(a.paper_train, &settings->paper_train)},
        std::pair{a.paper_match, sl::LoadMatchOptions(a.paper_match, &settings->paper_match)}}) {
    if (!status.ok()) return status;
  }
  return sl::Status::Ok();
}

// The sets to run: without --sets the development sets; --sets picks sets of either suite
// by name, and "swapped" names the whole swapped suite. Each cut to --tour-limit and
// --query-limit (a set's own limit stays when it is the smaller).
std::vector<sl::SuiteSet> SelectSets(const Args& a) {
  const auto named = [&a](const std::string& name) {
    return std::find(a.only.begin(), a.only.end(), name) != a.only.end();
  };
  std::vector<sl::SuiteSet> sets;
  const auto take = [&](sl::SuiteSet s, bool by_default) {
    const bool chosen =
        a.only.empty() ? by_default : named(s.name) || (!by_default && named("swapped"));
    if (!chosen) return;
    if (a.tour_limit > 0)
      s.tour_limit = s.tour_limit > 0 ? std::min(s.tour_limit, a.tour_limit) : a.tour_limit;
    if (a.query_limit > 0)
      s.query_limit = s.query_limit > 0 ? std::min(s.query_limit, a.query_limit) : a.query_limit;
    sets.push_back(std::move(s));
  };
  for (sl::SuiteSet s : sl::DevelopmentSuite(a.data_dir)) take(std::move(s), true);
  for (sl::SuiteSet s : sl::SwappedSuite(a.data_dir)) take(std::move(s), false);
  return sets;
}

// An error naming the first name in --sets that is neither a set of either suite nor
// "swapped", with the names there are; "" when every name is known.
std::string UnknownSetError(const Args& a) {
  std::vector<std::string> names;
  for (const auto& suite : {sl::DevelopmentSuite(a.data_dir), sl::SwappedSuite(a.data_dir)}) {
    for (const sl::SuiteSet& s : suite) names.push_back(s.name);
  }
  names.push_back("swapped");
  for (const std::string& name : a.only) {
    if (std::find(names.begin(), names.end(), name) != names.end()) continue;
    std::string known;
    for (const std::string& n : names) known += (known.empty() ? "" : ", ") + n;
    return "no set '" + name + "' in '" + a.data_dir + "' (there are: " + known + ")";
  }
  return "";
}

// One accuracy.csv row per method of a set.
void WriteCsvRows(const sl::SuiteSet& set, const sl::SetResult& result, std::ofstream* csv) {
  for (const Row& row : Rows(result)) {
    const sl::MethodSummary& m = *row.summary;
    *csv << set.name << ',' << row.method << ',' << result.outcomes.size() << ',' << m.match_rate[0]
         << ',' << m.match_rate[1] << ',' << m.match_rate[2] << ',' << m.match_rate[3] << ','
         << m.match_ms.median << ',' << m.match_ms.p90 << ',' << m.confidence.pr_auc << ','
         << m.confidence.recall_at_100_precision << ',' << m.confidence.ece << ','
         << m.confidence.ece_floor << ',' << m.confidence.correct_accepted << '\n';
  }
}

// accuracy.json's description of the run, before any set's figures.
nlohmann::json RunJson(const Args& a, const sl::SuiteSettings& settings) {
  nlohmann::json run = {{"host", Hostname()},
                        {"threads", a.context.threads},
                        {"hardware_threads", std::thread::hardware_concurrency()},
                        {"train_settings", sl::TrainOptionsToYaml(settings.train)},
                        {"match_settings", sl::MatchOptionsToYaml(settings.match)},
                        {"sets", nlohmann::json::array()}};
  if (!a.distractors_dir.empty()) {
    run["distractors"] = {{"dir", a.distractors_dir},
                          {"images", a.distractors.generated.size()},
                          {"locations", a.distractors.locations},
                          {"offroute", a.distractors.offroute_dir}};
  }
  return run;
}

// Every set with our settings: the table, OUT/accuracy.csv, .json and reliability.png.
int RunSuite(const Args& a, const sl::SuiteSettings& settings,
             const std::vector<sl::SuiteSet>& sets) {
  std::ofstream csv(a.out_dir + "/accuracy.csv");
  if (!csv) return Fail("cannot write to '" + a.out_dir + "'");
  csv << "set,method,queries,rate0,rate1,rate2,rate3,match_ms_median,match_ms_p90,pr_auc,"
         "recall_at_100_precision,ece,ece_floor,correct_accepted\n";
  nlohmann::json json = RunJson(a, settings);
  sl::Stopwatch total;
  std::vector<sl::SetResult> results;
  std::vector<sl::ReliabilityPanel> panels;
  PrintHeader();
  for (const sl::SuiteSet& set : sets) {
    std::fprintf(stderr, "sceneloc-accuracy: %s ...\n", set.name.c_str());
    sl::DistractorOptions distractors = a.distractors;
    distractors.progress = sl::ProgressPrinter("  " + set.name + ": padded map");
    auto result = a.distractors_dir.empty()
                      ? sl::RunSet(set, settings, a.context)
                      : sl::RunSetWithDistractors(set, settings, a.context, distractors);
    if (!result.ok()) return Fail(set.name + ": " + result.status().message());
    PrintSet(*result);
    json["sets"].push_back(SetJson(*result));
    WriteCsvRows(set, *result, &csv);
    panels.push_back({set.name + ": sceneloc", result->summary.ours.confidence});
    results.push_back(std::move(result).value());
  }
  const PooledSummaries pooled =
      PoolSets(results, {settings.train.tolerance, settings.match.min_confidence});
  PrintConfidenceTable(results, pooled, settings.match.min_confidence);
  for (const auto& [name, summary] :
       {std::pair<std::string, const sl::EvalSummary*>{"real", &pooled.real},
        {"all", &pooled.all}}) {
    nlohmann::json methods;
    for (const Row& row : SummaryRows(*summary, Comparisons(results))) {
      methods[row.method] = sl::MethodJson(*row.summary);
    }
    json["pooled"][name] = {{"queries", summary->queries}, {"methods", methods}};
  }
  PrintWalks(results);
  std::vector<sl::HeldOutInput> held;
  for (const sl::SetResult& r : results) {
    // A family: the sets of one query folder (a generated set is a family of its own).
    const std::string family = r.set.generated ? r.set.name : r.set.queries_dir;
    held.push_back({r.set.name, family, &r.shell, &r.outcomes,
                    r.session_outcomes.empty() ? nullptr : &r.session_outcomes});
  }
  const std::vector<sl::HeldOutSummary> left_out = sl::LeaveOneSetOut(
      held, settings.match, {settings.train.tolerance, settings.match.min_confidence});
  sl::PrintLeaveOneOut(left_out, settings.match.min_confidence);
  json["leave_one_out"] = sl::LeaveOneOutJson(left_out, settings.match.min_confidence);
  if (sl::Status w = sl::WriteReliabilityDiagram(panels, a.out_dir + "/reliability.png"); !w.ok()) {
    return Fail(w.message());
  }
  json["elapsed_s"] = total.Seconds();
  std::ofstream(a.out_dir + "/accuracy.json") << json.dump(1) << "\n";
  std::printf("%zu sets in %.0f s; %s/accuracy.json, accuracy.csv, reliability.png\n", sets.size(),
              total.Seconds(), a.out_dir.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "sceneloc-accuracy: every development set, ours beside the paper and both "
      "baselines on the same features"};
  app.set_version_flag("--version", std::string(sceneloc::Version()));
  Args a;
  AddOptions(&app, &a);
  CLI11_PARSE(app, argc, argv);
  a.context.cache_dir = a.cache_dir.empty() ? a.out_dir + "/cache" : a.cache_dir;
  if (const std::string unknown = UnknownSetError(a); !unknown.empty()) return Fail(unknown);
  sl::SuiteSettings settings;
  if (sl::Status loaded = LoadSettings(a, &settings); !loaded.ok()) return Fail(loaded.message());
  const std::vector<sl::SuiteSet> sets = SelectSets(a);
  if (sets.empty()) return Fail("no set to run: is '" + a.data_dir + "' the data folder?");
  if (a.only.empty() && std::all_of(sets.begin(), sets.end(), [](const sl::SuiteSet& s) {
        return s.generated.has_value();
      })) {
    return Fail("no data set under '" + a.data_dir +
                "' (gardens_point/, corridor/); --sets lookalike_street runs the generated set "
                "alone");
  }
  std::error_code ec;
  std::filesystem::create_directories(a.out_dir, ec);
  if (a.ablation) return RunAblation(sets, settings, a.variants, a.context, a.out_dir);
  if (!a.distractors_dir.empty()) {
    auto generated = sl::ListImageFiles(a.distractors_dir);
    if (!generated.ok()) return Fail(generated.status().message());
    a.distractors.generated = std::move(generated).value();
  }
  return RunSuite(a, settings, sets);
}
