// sceneloc-experiments: the paper's experiments (eta sweep, environment size) on a real tour.
//
//   sceneloc-experiments --tour DIR --queries DIR --out DIR --experiment NAME [options]
//
// Experiments (each writes OUT/NAME.csv, one row per run, ours and the baseline side by
// side on the same features; the ablation is sceneloc-accuracy --ablation, on every set):
//   single    one run with the given settings
//   eta       match rate, confidence and matching time against eta (paper Fig. 5)
//   size      eta_opt and its match rate against environment size (paper Fig. 6): the
//             first N tour images, the queries whose true location is among them
// scripts/plot_experiments.py turns the CSVs into PNG plots.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include "common/config/config.h"
#include "common/training/trainer.h"
#include "common/util/timer.h"
#include "common/util/version.h"
#include "tools/eval/evaluation.h"
#include "tools/eval/feature_cache.h"

namespace sceneloc {
namespace {

struct Settings {
  std::string name;
  TrainOptions train;
  MatchOptions match;
};

struct Data {
  std::vector<FeatureSet> tour, queries;
  std::vector<std::string> tour_names, query_names;
  std::vector<int> truth;
};

struct Context {
  std::string tour_dir, queries_dir, cache_dir;
  int threads = 2;
};

StatusOr<Data> LoadData(const Context& c, const ExtractorOptions& extractor) {
  Data d;
  SCENELOC_ASSIGN_OR_RETURN(
      d.tour, ExtractFolderCached(c.tour_dir, extractor, c.cache_dir, c.threads, &d.tour_names));
  ExtractionTarget frame;
  frame.width = d.tour.front().image_width;
  frame.height = d.tour.front().image_height;
  frame.holistic = d.tour.front().holistic_grid;
  SCENELOC_ASSIGN_OR_RETURN(d.queries, ExtractFolderCached(c.queries_dir, extractor, c.cache_dir,
                                                           c.threads, &d.query_names, &frame));
  SCENELOC_ASSIGN_OR_RETURN(d.truth, ResolveTruth(d.query_names, d.tour_names, {}));
  return d;
}

// The first `locations` tour images and the queries whose truth lies among them.
Data Prefix(const Data& all, int locations) {
  Data d;
  d.tour.assign(all.tour.begin(), all.tour.begin() + locations);
  d.tour_names.assign(all.tour_names.begin(), all.tour_names.begin() + locations);
  for (size_t q = 0; q < all.queries.size(); ++q) {
    if (all.truth[q] >= locations) continue;
    d.queries.push_back(all.queries[q]);
    d.query_names.push_back(all.query_names[q]);
    d.truth.push_back(all.truth[q]);
  }
  return d;
}

struct Row {
  std::string experiment, variant;
  int locations = 0, eta = 0, landmarks = 0;
  double train_s = 0;
  EvalSummary summary;
};

StatusOr<Row> Run(const std::string& experiment, const Settings& s, const Data& d, int threads) {
  Stopwatch watch;
  SCENELOC_ASSIGN_OR_RETURN(TrainResult trained,
                            TrainFromFeatures(d.tour, d.tour_names, s.train, threads, nullptr));
  Row row{experiment,
          s.name,
          static_cast<int>(d.tour.size()),
          s.train.eta,
          trained.map.num_landmarks(),
          watch.Seconds(),
          {}};
  std::vector<QueryOutcome> outcomes(d.queries.size());
  for (size_t q = 0; q < outcomes.size(); ++q) outcomes[q].truth = d.truth[q];
  SCENELOC_RETURN_IF_ERROR(
      RunQueries(d.queries, trained.map, s.match, threads, &d.tour, &outcomes));
  row.summary = Summarise(outcomes, true);
  return row;
}

class CsvWriter {
 public:
  explicit CsvWriter(const std::string& path) : out_(path) {
    out_ << "experiment,variant,locations,eta,landmarks,train_s,rate0,rate1,rate2,rate3,"
            "confidence,match_ms_median,match_ms_p90,baseline_rate0,baseline_rate1,"
            "baseline_rate2,baseline_rate3,baseline_confidence,baseline_ms_median,"
            "reranked_rate2,reranked_rate3\n";
  }
  bool ok() const { return static_cast<bool>(out_); }
  void Add(const Row& r) {
    const MethodSummary& o = r.summary.ours;
    const MethodSummary& b = r.summary.baseline;
    char line[512];
    std::snprintf(line, sizeof(line),
                  "%s,%s,%d,%d,%d,%.1f,%.3f,%.3f,%.3f,%.3f,%.3f,%.2f,%.2f,%.3f,%.3f,%.3f,%.3f,"
                  "%.3f,%.2f,%.3f,%.3f\n",
                  r.experiment.c_str(), r.variant.c_str(), r.locations, r.eta, r.landmarks,
                  r.train_s, o.match_rate[0], o.match_rate[1], o.match_rate[2], o.match_rate[3],
                  o.mean_confidence, o.match_ms.median, o.match_ms.p90, b.match_rate[0],
                  b.match_rate[1], b.match_rate[2], b.match_rate[3], b.mean_confidence,
                  b.match_ms.median, r.summary.reranked.match_rate[2],
                  r.summary.reranked.match_rate[3]);
    out_ << line << std::flush;
    std::printf(
        "%-10s %-28s N=%3d eta=%3d L=%6d  ±0 %.3f ±1 %.3f ±2 %.3f ±3 %.3f conf %.3f "
        "%.1f ms | baseline ±2 %.3f ±3 %.3f\n",
        r.experiment.c_str(), r.variant.c_str(), r.locations, r.eta, r.landmarks, o.match_rate[0],
        o.match_rate[1], o.match_rate[2], o.match_rate[3], o.mean_confidence, o.match_ms.median,
        b.match_rate[2], b.match_rate[3]);
    std::fflush(stdout);
  }

 private:
  std::ofstream out_;
};

}  // namespace
}  // namespace sceneloc

namespace sl = sceneloc;

namespace {

int Fail(const std::string& m) {
  std::fprintf(stderr, "sceneloc-experiments: %s\n", m.c_str());
  return 1;
}

// The command line.
struct Args {
  sl::Context c;
  std::string out_dir, experiment = "single", train_config, match_config, train_yaml, match_yaml;
  std::string variant_name = "default";
  std::vector<int> etas = {0, 10, 20, 30, 50, 75, 100, 150};
  std::vector<int> sizes = {25, 50, 100, 150, 200};
};

void AddOptions(CLI::App* app, Args* a) {
  sl::Context& c = a->c;
  c.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  app->add_option("--tour", c.tour_dir, "tour folder")->required();
  app->add_option("--queries", c.queries_dir, "query folder (truth: same file name)")->required();
  app->add_option("--out", a->out_dir, "folder for the CSV files")->required();
  app->add_option("--experiment", a->experiment, "single | eta | size")
      ->check(CLI::IsMember({"single", "eta", "size"}));
  app->add_option("--cache", c.cache_dir, "feature cache folder (default OUT/cache)");
  app->add_option("--train-config", a->train_config, "training settings file");
  app->add_option("--match-config", a->match_config, "matching settings file");
  app->add_option("--train-yaml", a->train_yaml, "training settings as YAML text, applied last");
  app->add_option("--match-yaml", a->match_yaml, "matching settings as YAML text, applied last");
  app->add_option("--name", a->variant_name, "variant name for the single experiment");
  app->add_option("--etas", a->etas, "eta values for the eta and size experiments")->delimiter(',');
  app->add_option("--sizes", a->sizes, "environment sizes for the size experiment")->delimiter(',');
  app->add_option("--threads", c.threads, "threads")->check(CLI::Range(1, 256));
}

// The settings every run starts from: the defaults, the settings files, then the YAML text.
sl::StatusOr<sl::Settings> BaseSettings(const Args& a) {
  sl::Settings base;
  base.name = a.variant_name;
  if (!a.train_config.empty()) {
    SCENELOC_RETURN_IF_ERROR(sl::LoadTrainOptions(a.train_config, &base.train));
  }
  if (!a.match_config.empty()) {
    SCENELOC_RETURN_IF_ERROR(sl::LoadMatchOptions(a.match_config, &base.match));
  }
  SCENELOC_RETURN_IF_ERROR(sl::ParseTrainOptions(a.train_yaml, "--train-yaml", &base.train));
  SCENELOC_RETURN_IF_ERROR(sl::ParseMatchOptions(a.match_yaml, "--match-yaml", &base.match));
  return base;
}

// The experiment's runs: the settings of each and the tour locations it uses (of `all`).
std::vector<std::pair<sl::Settings, int>> Plan(const Args& a, const sl::Settings& base, int all) {
  std::vector<std::pair<sl::Settings, int>> plan;
  if (a.experiment == "single") plan.push_back({base, all});
  if (a.experiment == "eta" || a.experiment == "size") {
    for (int n : a.experiment == "eta" ? std::vector<int>{all} : a.sizes) {
      for (int eta : a.etas) {
        sl::Settings v = base;
        v.train.eta = eta;
        v.name = "eta_" + std::to_string(eta);
        plan.push_back({v, std::min(n, all)});
      }
    }
  }
  return plan;
}

// Runs the plan on `data` (or, for a variant of the extractor, on its own features), one
// CSV row per run; the exit status.
int RunPlan(const Args& a, const sl::Settings& base, const sl::Data& data, sl::CsvWriter* csv) {
  auto run = [&](const sl::Settings& settings, const sl::Data& d) {
    auto row = sl::Run(a.experiment, settings, d, a.c.threads);
    if (!row.ok()) return Fail(settings.name + ": " + row.status().message());
    csv->Add(*row);
    return 0;
  };
  const int all = static_cast<int>(data.tour.size());
  for (const auto& [settings, n] : Plan(a, base, all)) {
    const bool same_features =
        settings.train.extractor.max_features == base.train.extractor.max_features &&
        settings.train.extractor.working_size == base.train.extractor.working_size;
    if (!same_features) {  // a variant of the extractor: its own (cached) features
      auto own = sl::LoadData(a.c, settings.train.extractor);
      if (!own.ok()) return Fail(own.status().message());
      if (const int rc = run(settings, *own); rc != 0) return rc;
      continue;
    }
    if (const int rc = run(settings, n == all ? data : sl::Prefix(data, n)); rc != 0) return rc;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"sceneloc-experiments: eta sweep and environment size on real data"};
  app.set_version_flag("--version", std::string(sceneloc::Version()));
  Args a;
  AddOptions(&app, &a);
  CLI11_PARSE(app, argc, argv);
  if (a.c.cache_dir.empty()) a.c.cache_dir = a.out_dir + "/cache";
  std::filesystem::create_directories(a.out_dir);
  auto base = BaseSettings(a);
  if (!base.ok()) return Fail(base.status().message());
  auto data = sl::LoadData(a.c, base->train.extractor);
  if (!data.ok()) return Fail(data.status().message());
  sl::CsvWriter csv(a.out_dir + "/" + a.experiment + ".csv");
  if (!csv.ok()) return Fail("cannot write to " + a.out_dir);
  return RunPlan(a, *base, *data, &csv);
}
