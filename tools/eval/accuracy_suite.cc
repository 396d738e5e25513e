#include "tools/eval/accuracy_suite.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgproc.hpp>
#include <random>

#include "common/features/extractor.h"
#include "common/image/image_codec.h"
#include "common/synthetic/tour_generator.h"
#include "common/training/trainer.h"
#include "common/util/file_io.h"
#include "common/util/image_folder.h"
#include "common/util/thread_pool.h"
#include "common/util/timer.h"
#include "tools/eval/feature_cache.h"
#include "tools/eval/leave_one_out.h"
#include "tools/eval/sequence_eval.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

// The changed image and the JPEG quality it is stored at.
std::pair<cv::Mat, int> Change(const cv::Mat& image, QueryChange change, uint32_t seed) {
  cv::Mat out;
  switch (change) {
    case QueryChange::kSmaller:  // a camera of a third of the resolution
      cv::resize(image, out, cv::Size(), 1.0 / 3.0, 1.0 / 3.0, cv::INTER_AREA);
      return {out, 95};
    case QueryChange::kDarker: {  // dusk: a third of the light, crushed shadows, sensor noise
      cv::Mat f, noise(image.size(), CV_32FC3);
      image.convertTo(f, CV_32FC3, 1.0 / 255.0);
      cv::pow(f, 2.2, f);
      cv::RNG rng(seed);
      rng.fill(noise, cv::RNG::NORMAL, 0.0, 3.0);
      f = f * (255.0 * 0.35) + noise;
      f.convertTo(out, CV_8UC3);
      return {out, 95};
    }
    case QueryChange::kJpeg:  // a bandwidth-starved link
      return {image.clone(), 8};
    case QueryChange::kBlur: {  // motion or focus blur: sigma of 3 px at 960 wide
      const double sigma = 3.0 * image.cols / 960.0;
      cv::GaussianBlur(image, out, cv::Size(), sigma);
      return {out, 95};
    }
    case QueryChange::kZoom:  // a narrower lens: the centre 80% of the view, 1.25x larger
      return {image(cv::Rect(image.cols / 10, image.rows / 10, image.cols * 8 / 10,
                             image.rows * 8 / 10))
                  .clone(),
              95};
    case QueryChange::kSensor43: {  // a 4:3 sensor of the same height: the sides cut off
      const int width = std::min(image.cols, image.rows * 4 / 3);
      return {image(cv::Rect((image.cols - width) / 2, 0, width, image.rows)).clone(), 95};
    }
    case QueryChange::kRoll: {  // mounted 5 degrees off level: rotated, the corners cut off
      const cv::Mat turn = cv::getRotationMatrix2D(
          cv::Point2f(static_cast<float>(image.cols) / 2, static_cast<float>(image.rows) / 2), 5,
          1.0);
      cv::warpAffine(image, out, turn, image.size(), cv::INTER_LINEAR);
      return {out(cv::Rect(image.cols / 12, image.rows / 12, image.cols * 10 / 12,
                           image.rows * 10 / 12))
                  .clone(),
              95};
    }
    case QueryChange::kNone:
      break;
  }
  return {image, 95};
}

// The first `limit` (0 = all) images of a folder.
StatusOr<std::vector<std::string>> FirstImages(const std::string& dir, int limit) {
  SCENELOC_ASSIGN_OR_RETURN(std::vector<std::string> paths, ListImageFiles(dir));
  if (limit > 0 && static_cast<size_t>(limit) < paths.size()) paths.resize(limit);
  return paths;
}

// What a generated variant was made from: its source file (path, size, modification time)
// and how it was changed. Bump kVariantVersion when Change() changes what it writes.
constexpr int kVariantVersion = 1;
std::string VariantStamp(const std::string& source, QueryChange change) {
  std::error_code ec;
  const auto size = fs::file_size(source, ec);
  const auto mtime = fs::last_write_time(source, ec).time_since_epoch().count();
  return "sceneloc variant " + std::to_string(kVariantVersion) + "\n" + source + "\n" +
         std::to_string(size) + "\n" + std::to_string(mtime) + "\n" + QueryChangeName(change) +
         "\n";
}

bool ReadsAs(const fs::path& path, const std::string& expected) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return text == expected;
}

// A stamp is written after its variant: a torn or missing one only reads as a mismatch, so
// the variant is made again.
Status WriteStamp(const fs::path& path, const std::string& stamp) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << stamp;
  if (!out.flush()) return IoError("cannot write '" + path.string() + "'");
  return Status::Ok();
}

// Writes the changed queries into cache_dir/variants/<set> and returns their paths. A
// variant is made again when its stamp (<file>.stamp) does not match its source any more:
// a source replaced or touched, a variant of an older generator, or one without a stamp.
StatusOr<std::vector<std::string>> ChangedQueries(const SuiteSet& set,
                                                  const std::vector<std::string>& paths,
                                                  const std::string& cache_dir) {
  if (cache_dir.empty()) return InvalidArgument("generated variants need a cache folder");
  const fs::path dir =
      fs::path(cache_dir) / "variants" / (set.name + "_" + std::to_string(paths.size()));
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return IoError("cannot create '" + dir.string() + "': " + ec.message());
  std::vector<std::string> out;
  for (size_t i = 0; i < paths.size(); ++i) {
    const fs::path target = dir / FileName(paths[i]);
    const fs::path stamp_path = target.string() + ".stamp";
    out.push_back(target.string());
    const std::string stamp = VariantStamp(paths[i], set.change);
    if (fs::is_regular_file(target) && ReadsAs(stamp_path, stamp)) continue;
    SCENELOC_ASSIGN_OR_RETURN(const cv::Mat image, ReadImageFile(paths[i]));
    const auto [changed, quality] = Change(image, set.change, static_cast<uint32_t>(i));
    SCENELOC_ASSIGN_OR_RETURN(const std::string jpeg, EncodeJpeg(changed, quality));
    SCENELOC_RETURN_IF_ERROR(WriteFileAtomically(target.string(), jpeg));
    SCENELOC_RETURN_IF_ERROR(WriteStamp(stamp_path, stamp));
  }
  return out;
}

// What a generated set was rendered with. Bump kGeneratedVersion when the tour generator
// changes what it draws for the same options.
constexpr int kGeneratedVersion = 1;
std::string GeneratedStamp(const TourOptions& o) {
  std::string stamp = "sceneloc generated " + std::to_string(kGeneratedVersion);
  for (const double v :
       {double(o.num_locations), double(o.image_width), double(o.image_height), double(o.seed),
        o.step, o.lateral_shift, o.forward_offset, o.rotation_deg, o.brightness_gain,
        o.brightness_offset, o.noise_stddev, double(o.jpeg_quality), double(o.repeat_blocks)}) {
    stamp += " " + std::to_string(v);
  }
  return stamp + "\n";
}

// The tour and query folders of `set`: its own, or for a generated set the cache's copy of
// its rendering (made first when missing or of other options).
struct Folders {
  std::string tour, queries;
};
StatusOr<Folders> FoldersOf(const SuiteSet& set, const SuiteContext& context) {
  if (!set.generated) return Folders{set.tour_dir, set.queries_dir};
  if (context.cache_dir.empty()) return InvalidArgument("generated sets need a cache folder");
  const TourOptions& options = *set.generated;
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  const std::string stamp = GeneratedStamp(options);
  const fs::path dir = fs::path(context.cache_dir) / "generated" / set.name;
  const Folders folders{(dir / "tour").string(), (dir / "test").string()};
  const fs::path stamp_path = dir / "stamp";
  if (ReadsAs(stamp_path, stamp)) return folders;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return IoError("cannot create '" + dir.string() + "': " + ec.message());
  for (const auto& [folder, pass] :
       {std::pair{folders.tour, kTrainingPass}, std::pair{folders.queries, kTestPass}}) {
    SCENELOC_RETURN_IF_ERROR(WriteTour(options, folder, pass, context.threads));
  }
  SCENELOC_RETURN_IF_ERROR(WriteStamp(stamp_path, stamp));
  return folders;
}

std::vector<std::string> Names(const std::vector<std::string>& paths) {
  std::vector<std::string> names;
  for (const std::string& p : paths) names.push_back(FileName(p));
  return names;
}

}  // namespace

const char* QueryChangeName(QueryChange change) {
  switch (change) {
    case QueryChange::kNone:
      return "none";
    case QueryChange::kSmaller:
      return "smaller";
    case QueryChange::kDarker:
      return "darker";
    case QueryChange::kJpeg:
      return "jpeg";
    case QueryChange::kBlur:
      return "blur";
    case QueryChange::kZoom:
      return "zoom";
    case QueryChange::kSensor43:
      return "sensor_4_3";
    case QueryChange::kRoll:
      return "roll";
  }
  return "";
}

namespace {

// The sets whose tour and query folders exist, each without its missing negative folders.
std::vector<SuiteSet> Present(std::vector<SuiteSet> all) {
  std::vector<SuiteSet> present;
  for (SuiteSet s : all) {
    if (!s.generated && (!fs::is_directory(s.tour_dir) || !fs::is_directory(s.queries_dir))) {
      continue;
    }
    s.negative_dirs.erase(std::remove_if(s.negative_dirs.begin(), s.negative_dirs.end(),
                                         [](const std::string& d) { return !fs::is_directory(d); }),
                          s.negative_dirs.end());
    present.push_back(s);
  }
  return present;
}

// The other data set's frames, which the maps of `data_dir`'s sets must not localise.
struct Negatives {
  std::vector<std::string> not_gp, not_corridor;
};
Negatives NegativesOf(const std::string& gp, const std::string& corridor) {
  return {{corridor + "/ref", corridor + "/query"},
          {gp + "/day_left", gp + "/day_right", gp + "/night_right"}};
}

}  // namespace

std::vector<SuiteSet> DevelopmentSuite(const std::string& data_dir) {
  const std::string gp = data_dir + "/gardens_point", corridor = data_dir + "/corridor";
  // Every frame of the other data set is a frame from elsewhere for these maps.
  const auto [not_gp, not_corridor] = NegativesOf(gp, corridor);
  std::vector<SuiteSet> all = {
      {"gp_day", "Gardens Point day: day_left (200) -> day_right", gp + "/day_left", 0,
       gp + "/day_right", 0, QueryChange::kNone, not_gp, std::nullopt},
      {"gp_night_same", "Gardens Point night, same side: day_right 000-099 -> night_right",
       gp + "/day_right", 100, gp + "/night_right", 0, QueryChange::kNone, not_gp, std::nullopt},
      {"gp_night_other",
       "Gardens Point night, other side: day_left (200) -> night_right",
       gp + "/day_left",
       0,
       gp + "/night_right",
       0,
       QueryChange::kNone,
       {},
       std::nullopt},
      {"corridor", "corridor fish-eye 160x120: ref (111) -> query", corridor + "/ref", 0,
       corridor + "/query", 0, QueryChange::kNone, not_corridor, std::nullopt},
      {"gp_day_smaller",
       "generated: GP day queries from a camera of 1/3 the resolution",
       gp + "/day_left",
       0,
       gp + "/day_right",
       0,
       QueryChange::kSmaller,
       {},
       std::nullopt},
      {"gp_day_darker",
       "generated: GP day queries at dusk (gamma 2.2, 35% light, noise)",
       gp + "/day_left",
       0,
       gp + "/day_right",
       0,
       QueryChange::kDarker,
       {},
       std::nullopt},
      {"gp_day_jpeg",
       "generated: GP day queries as JPEG quality 8",
       gp + "/day_left",
       0,
       gp + "/day_right",
       0,
       QueryChange::kJpeg,
       {},
       std::nullopt},
      {"gp_day_blur",
       "generated: GP day queries blurred (sigma 3 px at 960 wide)",
       gp + "/day_left",
       0,
       gp + "/day_right",
       0,
       QueryChange::kBlur,
       {},
       std::nullopt},
      {"gp_day_zoom",
       "generated: GP day queries through a narrower lens (the centre 80%)",
       gp + "/day_left",
       0,
       gp + "/day_right",
       0,
       QueryChange::kZoom,
       {},
       std::nullopt},
      {"gp_day_4_3",
       "generated: GP day queries from a 4:3 sensor of the same height",
       gp + "/day_left",
       0,
       gp + "/day_right",
       0,
       QueryChange::kSensor43,
       {},
       std::nullopt},
      {"gp_day_roll",
       "generated: GP day queries from a camera rolled 5 degrees",
       gp + "/day_left",
       0,
       gp + "/day_right",
       0,
       QueryChange::kRoll,
       {},
       std::nullopt},
  };
  SuiteSet street;
  street.name = "lookalike_street";
  street.description =
      "generated: a street whose places repeat every 40 locations (120), walked again displaced "
      "and darker";
  street.negative_dirs = not_gp;
  street.negative_dirs.insert(street.negative_dirs.end(), not_corridor.begin(), not_corridor.end());
  street.generated = LookAlikeStreet();
  all.push_back(std::move(street));
  return Present(std::move(all));
}

TourOptions LookAlikeStreet() {
  TourOptions street;
  street.num_locations = 120;
  street.repeat_blocks = 3;
  return street;
}

std::vector<SuiteSet> SwappedSuite(const std::string& data_dir) {
  const std::string gp = data_dir + "/gardens_point", corridor = data_dir + "/corridor";
  const auto [not_gp, not_corridor] = NegativesOf(gp, corridor);
  return Present({
      {"gp_day_swapped", "Gardens Point day, swapped: day_right (100) -> day_left 000-099",
       gp + "/day_right", 0, gp + "/day_left", 100, QueryChange::kNone, not_gp, std::nullopt},
      {"gp_night_swapped", "Gardens Point, a night map: night_right (100) -> day_right",
       gp + "/night_right", 0, gp + "/day_right", 0, QueryChange::kNone, not_gp, std::nullopt},
      {"corridor_swapped", "corridor, swapped: query (55) -> ref 0000000-0000054",
       corridor + "/query", 0, corridor + "/ref", 55, QueryChange::kNone, not_corridor,
       std::nullopt},
  });
}

StatusOr<SetData> LoadSet(const SuiteSet& set, const ExtractorOptions& extractor,
                          const SuiteContext& context) {
  SetData d;
  d.extractor = extractor;
  SCENELOC_ASSIGN_OR_RETURN(const Folders folders, FoldersOf(set, context));
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<std::string> tour_paths,
                            FirstImages(folders.tour, set.tour_limit));
  SCENELOC_ASSIGN_OR_RETURN(std::vector<std::string> query_paths,
                            FirstImages(folders.queries, set.query_limit));
  d.tour_dir = folders.tour;
  d.queries_dir = folders.queries;
  d.tour_names = Names(tour_paths);
  d.query_names = Names(query_paths);
  if (set.change != QueryChange::kNone) {
    SCENELOC_ASSIGN_OR_RETURN(query_paths, ChangedQueries(set, query_paths, context.cache_dir));
  }
  SCENELOC_ASSIGN_OR_RETURN(
      d.tour, ExtractCached(tour_paths, extractor, context.cache_dir, context.threads));
  ExtractionTarget frame;
  frame.width = d.tour.front().image_width;
  frame.height = d.tour.front().image_height;
  frame.holistic = d.tour.front().holistic_grid;
  SCENELOC_ASSIGN_OR_RETURN(
      d.queries, ExtractCached(query_paths, extractor, context.cache_dir, context.threads, &frame));
  SCENELOC_ASSIGN_OR_RETURN(d.truth, ResolveTruth(d.query_names, d.tour_names, {}));
  return d;
}

StatusOr<VariantResult> RunVariant(const SetData& data, const TrainOptions& train,
                                   const MatchOptions& match, const SuiteContext& context) {
  VariantResult r;
  Stopwatch watch;
  SCENELOC_ASSIGN_OR_RETURN(
      TrainResult trained,
      TrainFromFeatures(data.tour, data.tour_names, train, context.threads, nullptr));
  r.train_seconds = watch.Seconds();
  r.landmarks = trained.map.num_landmarks();
  r.map = std::move(trained.map);
  r.outcomes.resize(data.queries.size());
  for (size_t q = 0; q < data.queries.size(); ++q) {
    r.outcomes[q].name = data.query_names[q];
    r.outcomes[q].truth = data.truth[q];
  }
  SCENELOC_RETURN_IF_ERROR(RunOurs(data.queries, r.map, match, context.threads, &r.outcomes));
  r.summary = SummariseMethod(r.outcomes, Method::kOurs, {train.tolerance, match.min_confidence});
  return r;
}

// Localises every frame of set.negative_dirs against `map`: how many come back LOCALISED.
Status RunNegatives(const SuiteSet& set, const Map& map, const MatchOptions& match,
                    const SetData& data, const SuiteContext& context, SetResult* result) {
  ExtractionTarget frame;
  frame.width = map.image_width;
  frame.height = map.image_height;
  frame.holistic = map.holistic_grid;
  ThreadPool pool(context.threads);
  for (const std::string& dir : set.negative_dirs) {
    SCENELOC_ASSIGN_OR_RETURN(const std::vector<std::string> paths, ListImageFiles(dir));
    SCENELOC_ASSIGN_OR_RETURN(
        const std::vector<FeatureSet> frames,
        ExtractCached(paths, data.extractor, context.cache_dir, context.threads, &frame));
    for (const FeatureSet& f : frames) {
      SCENELOC_ASSIGN_OR_RETURN(const LocaliseResult r, Localise(f, map, match, &pool));
      ++result->negatives;
      result->negatives_accepted += r.decision == Decision::kLocalised;
      result->negatives_max_confidence = std::max(result->negatives_max_confidence, r.confidence);
    }
  }
  return Status::Ok();
}

EvalSummary PooledSummary(const std::vector<SetResult>& results, bool unchanged_only,
                          const Judging& judging) {
  std::vector<QueryOutcome> pooled;
  for (const SetResult& r : results) {
    if (unchanged_only && (r.set.change != QueryChange::kNone || r.set.generated)) continue;
    pooled.insert(pooled.end(), r.outcomes.begin(), r.outcomes.end());
  }
  return Summarise(pooled, /*with_baseline=*/true, judging);
}

StatusOr<SetResult> RunSet(const SuiteSet& set, const SuiteSettings& settings,
                           const SuiteContext& context) {
  SetResult result;
  result.set = set;
  SCENELOC_ASSIGN_OR_RETURN(const SetData data, LoadSet(set, settings.train.extractor, context));
  result.set.tour_dir = data.tour_dir;  // a generated set's: where it was rendered
  result.set.queries_dir = data.queries_dir;
  SCENELOC_ASSIGN_OR_RETURN(VariantResult ours,
                            RunVariant(data, settings.train, settings.match, context));
  // The paper's map from the same tour features: its extractor settings are ours.
  TrainOptions paper_train = settings.paper_train;
  paper_train.extractor = settings.train.extractor;
  SCENELOC_ASSIGN_OR_RETURN(const VariantResult paper,
                            RunVariant(data, paper_train, settings.paper_match, context));
  result.locations = static_cast<int>(data.tour.size());
  result.landmarks = ours.landmarks;
  result.train_seconds = ours.train_seconds;
  result.outcomes = std::move(ours.outcomes);
  SCENELOC_RETURN_IF_ERROR(RunBaselines(data.queries, data.tour,
                                        settings.match.verify_ransac_threshold, &result.outcomes));
  SCENELOC_RETURN_IF_ERROR(RunNegatives(set, ours.map, settings.match, data, context, &result));
  for (const QueryOutcome& o : paper.outcomes) result.paper_outcomes.push_back(o.ours);
  result.summary = Summarise(result.outcomes, /*with_baseline=*/true,
                             {settings.train.tolerance, settings.match.min_confidence});
  result.paper = paper.summary;
  SummariseSessions(ours.map, settings, &result);
  result.shell = MapShell(ours.map);
  return result;
}

void SummariseSessions(const Map& map, const SuiteSettings& settings, SetResult* out) {
  SetResult& result = *out;
  const Map& ours_map = map;
  const SequenceRun run = RunSequence(result.outcomes, ours_map, settings.match,
                                      KidnapOrder(result.outcomes.size(), 1, 0));
  for (const QueryOutcome& o : run.filtered) result.session_outcomes.push_back(o.ours);
  for (const QueryOutcome& o : run.in_session) result.in_session_outcomes.push_back(o.ours);
  result.in_session = SummariseMethod(run.in_session, Method::kOurs,
                                      {settings.train.tolerance, settings.match.min_confidence});
  result.session =
      SummariseMethod(run.filtered, Method::kOurs,
                      {settings.train.tolerance, settings.match.sequence.min_confidence});
  for (const Walk& walk : StandardWalks(result.outcomes.size())) {
    result.walks.push_back(SummariseWalk(walk, result.outcomes, ours_map, settings.match));
  }
  result.kidnap = SummariseKidnaps(result.outcomes, ours_map, settings.match,
                                   SetResult::kKidnapSegments, SetResult::kKidnapSeeds);
}

std::vector<AblationVariant> AblationVariants() {
  return {
      {"default", "", ""},
      {"paper_as_printed", "@paper", "@paper"},
      {"holistic_only", "", "matching: {verify_weight: 0}"},
      {"no_holistic", "", "matching: {use_holistic: false}"},
      {"no_holistic_shift", "extractor: {holistic_max_shift: 0}", ""},
      {"no_verification", "", "matching: {verify_top: 0, use_holistic: false}"},
      {"no_angle_check", "", "matching: {verify_angle_tolerance: 0}"},
      {"no_scale_cue", "", "matching: {verify_scale_sigma: 0}"},
      {"s_d_only", "", "matching: {use_neighbourhood: false}"},
      {"no_coverage", "tracking: {min_landmarks_per_image: 0}", ""},
      {"paper_variance_floors", "landmarks: {local_var_floor: 0.02, context_var_floor: 0.002}", ""},
      {"eta_all", "selection: {eta: 0}", ""},
      {"working_size_320", "extractor: {working_size: 320}", ""},
      {"working_size_640", "extractor: {working_size: 640}", ""},
      {"clahe", "extractor: {clahe_clip: 2.0}", ""},
      {"root_sift", "extractor: {root_sift: true}", ""},
      {"contrast_0.02", "extractor: {contrast_threshold: 0.02}", ""},
      {"contrast_0.01", "extractor: {contrast_threshold: 0.01}", ""},
  };
}

}  // namespace sceneloc
