// The accuracy suite: every development data set, each localised by our default settings,
// by the paper as printed, by the voting baseline and by the baseline re-ranked by RANSAC
// inliers, all four on the same features in one run, and ours again with the queries in
// file order as one robot's session (sequence_filter.h). sceneloc-accuracy prints and
// writes its results; the real-data floor tests run slices of it.
//
// A set is a tour folder, a query folder (truth: the tour image of the same file name) and
// optionally a change applied to every query image first (a generated variant: a smaller
// camera, a darker scene, heavy JPEG compression, blur), written as JPEG files once.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "common/map/map.h"
#include "common/map/train_options.h"
#include "common/matching/localiser.h"
#include "common/synthetic/tour_generator.h"
#include "common/util/status.h"
#include "tools/eval/evaluation.h"
#include "tools/eval/sequence_eval.h"

namespace sceneloc {

// How a variant changes each query image before it is extracted.
// kZoom, kSensor43 and kRoll are other cameras than the tour's: a narrower lens, a 4:3
// sensor, a camera mounted off level.
enum class QueryChange { kNone, kSmaller, kDarker, kJpeg, kBlur, kZoom, kSensor43, kRoll };
const char* QueryChangeName(QueryChange change);

struct SuiteSet {
  std::string name;  // e.g. "gp_night_same"
  std::string description;
  std::string tour_dir;
  int tour_limit = 0;  // the first N tour images (0 = all)
  std::string queries_dir;
  int query_limit = 0;  // the first N query images (0 = all)
  QueryChange change = QueryChange::kNone;
  // Folders of frames from elsewhere (another route): every one should come back UNKNOWN.
  std::vector<std::string> negative_dirs;
  // A generated set: tour_dir and queries_dir are empty, and LoadSet renders the tour
  // (kTrainingPass) and the queries (kTestPass) of these options into the cache first.
  std::optional<TourOptions> generated;
};

// The development sets under `data_dir` (../shared/data): Gardens Point day, night on the
// same and on the other side of the path, the corridor, and seven generated variants of the
// Gardens Point day queries (four of the image, three of the camera). Sets whose folders are
// missing are left out. Then, whatever `data_dir` holds, a generated street of look-alike
// places ("lookalike_street": LookAlikeStreet()), with the real frames as its negatives.
std::vector<SuiteSet> DevelopmentSuite(const std::string& data_dir);

// The look-alike street: 120 locations whose facades and pillars repeat every 3 blocks (40
// locations), so the route passes its first places' twins twice more, each twin told apart
// only by a small sign per facade tile; the queries walk it again displaced and darker.
// A corridor of identical doors, or a route that comes back past its start: the map's own
// places look alike, and the confidence has to know it.
TourOptions LookAlikeStreet();

// The real sets with tour and queries swapped: a map from `day_right` (100) queried with
// `day_left` 000-099, a map from the night walk queried with the day walk, a map from the
// corridor's `query` (55) queried with `ref` 0000000-0000054. Nothing was tuned on these
// maps, so they check that the settings hold on data the suite does not run by default
// (sceneloc-accuracy --sets swapped). Missing folders are left out, as above.
std::vector<SuiteSet> SwappedSuite(const std::string& data_dir);

// The settings of the two engine rows: our defaults and the paper as printed.
struct SuiteSettings {
  TrainOptions train;
  MatchOptions match;
  TrainOptions paper_train;
  MatchOptions paper_match;
};

struct SetResult {
  SuiteSet set;
  int locations = 0;
  int landmarks = 0;
  double train_seconds = 0;
  size_t tour_mixed_sizes = 0;
  EvalSummary summary;                 // ours, the baseline and the re-ranked baseline
  MethodSummary paper;                 // the paper as printed
  std::vector<QueryOutcome> outcomes;  // per query (ours, baselines)
  std::vector<MethodOutcome> paper_outcomes;
  // Ours with the queries in file order as one robot's session (sequence_eval.h), judged
  // at the session's min_confidence.
  MethodSummary session;
  std::vector<MethodOutcome> session_outcomes;
  // Ours one frame at a time as the session's requests get them: read with the camera the
  // session has learnt (SequenceRun::in_session), judged at matching's min_confidence.
  MethodSummary in_session;
  std::vector<MethodOutcome> in_session_outcomes;
  // The session on every walk of StandardWalks, and the kidnapped robot (5 segments, 5
  // seeds), on the same single-frame evidence.
  std::vector<WalkSummary> walks;
  KidnapSummary kidnap;
  static constexpr int kKidnapSegments = 5;
  static constexpr int kKidnapSeeds = 5;
  // Frames of set.negative_dirs: how many our map would LOCALISE, and their highest
  // confidence.
  size_t negatives = 0;
  size_t negatives_accepted = 0;
  float negatives_max_confidence = 0;
  // Whether the paper's map and the baselines ran (not with distractors: distractor_suite.h).
  bool comparisons = true;
  // What of our map the confidence reads (leave_one_out.h: MapShell), to read the answers
  // again with other constants.
  Map shell;
};

struct SuiteContext {
  std::string cache_dir;  // extracted features and generated variants ("" = no cache); a variant
                          // is made again when its source changes (a stamp beside it)
  int threads = 2;
};

// Trains both maps of one set from the same tour features and localises its queries with
// all four methods. Errors: unreadable folders or images, a tour that cannot be trained.
StatusOr<SetResult> RunSet(const SuiteSet& set, const SuiteSettings& settings,
                           const SuiteContext& context);

// Fills the session figures of `result` (session, in_session, walks, kidnap) from its
// single-frame outcomes against `map`, as RunSet does.
void SummariseSessions(const Map& map, const SuiteSettings& settings, SetResult* result);

// Every single-frame query of `results` (with `unchanged_only`, of the real sets: query
// frames used as they are, and no generated tour) in one summary of ours and both baselines, each
// query judged against its own set's truth. One set's 55-100 queries put the ECE's sampling floor
// (what a perfectly calibrated confidence would measure) at 0.05-0.10 by itself; pooled, the floor
// falls to a few hundredths and the calibration itself shows.
EvalSummary PooledSummary(const std::vector<SetResult>& results, bool unchanged_only,
                          const Judging& judging);

// A set's features, extracted (or read from the cache) with one extractor's settings.
// A generated set's images are rendered into context.cache_dir/generated/<name> once
// (a stamp beside them names the options; bump kGeneratedVersion in accuracy_suite.cc when
// the generator changes what it draws).
struct SetData {
  ExtractorOptions extractor;         // what they were extracted with
  std::string tour_dir, queries_dir;  // where the images are (a generated set's: the cache)
  std::vector<FeatureSet> tour, queries;
  std::vector<std::string> tour_names, query_names;
  std::vector<int> truth;
};
StatusOr<SetData> LoadSet(const SuiteSet& set, const ExtractorOptions& extractor,
                          const SuiteContext& context);

// One engine variant on a loaded set: trains with `train` (whose extractor settings must be
// those the data was extracted with) and localises every query with `match`.
struct VariantResult {
  Map map;  // the map trained
  MethodSummary summary;
  std::vector<QueryOutcome> outcomes;
  int landmarks = 0;
  double train_seconds = 0;
};
StatusOr<VariantResult> RunVariant(const SetData& data, const TrainOptions& train,
                                   const MatchOptions& match, const SuiteContext& context);

// The ablation: our defaults, the paper as printed and each of our departures taken away
// (or a lighting option added) one at a time, as YAML overrides of the two settings files.
struct AblationVariant {
  std::string name;
  std::string train_yaml;
  std::string match_yaml;
};
std::vector<AblationVariant> AblationVariants();

// Localises every frame of set.negative_dirs against `map` (in the frame of `data`'s tour):
// fills result->negatives, negatives_accepted and negatives_max_confidence.
Status RunNegatives(const SuiteSet& set, const Map& map, const MatchOptions& match,
                    const SetData& data, const SuiteContext& context, SetResult* result);

}  // namespace sceneloc
