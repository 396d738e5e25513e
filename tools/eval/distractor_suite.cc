#include "tools/eval/distractor_suite.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <sstream>

#include "common/config/config.h"
#include "common/map/map_io.h"
#include "common/training/trainer.h"
#include "common/util/image_folder.h"
#include "common/util/timer.h"
#include "tools/eval/evaluation.h"
#include "tools/eval/leave_one_out.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

// A tour whose first images are held in memory and the rest read from a spool.
class ConcatTour : public TourFeatures {
 public:
  ConcatTour(const std::vector<FeatureSet>& first, const TourFeatures& rest)
      : first_(first), rest_(rest) {}
  size_t size() const override { return first_.size() + rest_.size(); }
  StatusOr<TourWindow> Window(size_t begin, size_t end) const override {
    std::vector<FeatureSet> sets;
    for (size_t i = begin; i < std::min(end, first_.size()); ++i) sets.push_back(first_[i]);
    if (end > first_.size()) {
      const size_t from = std::max(begin, first_.size()) - first_.size();
      SCENELOC_ASSIGN_OR_RETURN(TourWindow rest, rest_.Window(from, end - first_.size()));
      for (size_t i = rest.first(); i < rest.end(); ++i) sets.push_back(rest[i]);
    }
    return TourWindow(begin, std::move(sets));
  }

 private:
  const std::vector<FeatureSet>& first_;
  const TourFeatures& rest_;
};

// The images that pad `set`'s tour of `tour_size` to options.locations: the frames of its
// negative folders (another building), then the generated ones.
StatusOr<std::vector<std::string>> Padding(const SuiteSet& set, size_t tour_size,
                                           const DistractorOptions& options) {
  if (static_cast<size_t>(options.locations) < tour_size) {
    return InvalidArgument("--distractor-locations " + std::to_string(options.locations) +
                           " is below the " + std::to_string(tour_size) + " locations of " +
                           set.name + "'s tour");
  }
  const size_t wanted = static_cast<size_t>(options.locations) - tour_size;
  std::vector<std::string> paths;
  for (const std::string& dir : set.negative_dirs) {
    SCENELOC_ASSIGN_OR_RETURN(const std::vector<std::string> frames, ListImageFiles(dir));
    paths.insert(paths.end(), frames.begin(), frames.end());
  }
  if (paths.size() > wanted) paths.resize(wanted);
  const size_t generated = wanted - paths.size();
  if (options.generated.size() < generated) {
    return InvalidArgument(set.name + " needs " + std::to_string(generated) +
                           " generated distractors, --distractors holds " +
                           std::to_string(options.generated.size()));
  }
  paths.insert(paths.end(), options.generated.begin(),
               options.generated.begin() + static_cast<std::ptrdiff_t>(generated));
  return paths;
}

// What a padded map is made of, as text: its cache entry holds it, so an entry made from
// other images or settings, or stored in another map format (made by a trainer that stored
// other things), is a miss. Paths are canonical: the same data reached through
// another spelling (a relative --data) finds the same entry.
std::string MapKey(const SetData& data, const std::vector<std::string>& padding,
                   const TrainOptions& train) {
  std::ostringstream key;
  key << "sceneloc padded map 1\nmap format " << kMapFormatVersion << '\n'
      << TrainOptionsToYaml(train);
  for (const std::string& name : data.tour_names) key << name << '\n';
  for (const std::string& path : padding) {
    std::error_code ec;
    fs::path canonical = fs::weakly_canonical(path, ec);
    if (ec) canonical = fs::absolute(path);
    key << canonical.string() << '\t' << fs::file_size(path, ec) << '\n';
  }
  return key.str();
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// Trains the padded map: the set's tour from memory, the padding extracted (into the tour's
// frame, as queries would be) to a spool in the cache folder.
StatusOr<Map> TrainPadded(const SetData& data, const std::vector<std::string>& padding,
                          const TrainOptions& train, const SuiteContext& context,
                          const ProgressFn& progress) {
  SCENELOC_ASSIGN_OR_RETURN(const auto spool, FeatureSpool::Create(context.cache_dir));
  const ExtractionTarget frame{data.tour.front().image_width, data.tour.front().image_height,
                               data.tour.front().holistic_grid};
  const TargetFn target = [&](int width, int height) {
    return QueryTarget(width, height, frame.width, frame.holistic);
  };
  SCENELOC_RETURN_IF_ERROR(
      ExtractToSpool(padding, train.extractor, target, context.threads, progress, spool.get()));
  std::vector<std::string> names = data.tour_names;
  for (size_t i = 0; i < padding.size(); ++i) {
    names.push_back("padding/" + std::to_string(i) + "/" + FileName(padding[i]));
  }
  SCENELOC_ASSIGN_OR_RETURN(TrainResult trained, TrainFromTour(ConcatTour(data.tour, *spool), names,
                                                               train, context.threads, progress));
  return std::move(trained.map);
}

// The padded map of `data`'s tour, from the cache folder or trained (and kept there).
StatusOr<Map> PaddedMap(const SuiteSet& set, const SetData& data, const TrainOptions& train,
                        const SuiteContext& context, const DistractorOptions& options,
                        double* train_seconds) {
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<std::string> padding,
                            Padding(set, data.tour.size(), options));
  const std::string key = MapKey(data, padding, train);
  std::ostringstream name;
  name << std::hex << std::hash<std::string>{}(key);
  const fs::path dir = fs::path(context.cache_dir) / "padded";
  const fs::path map_path = dir / (name.str() + ".scnl"), key_path = dir / (name.str() + ".key");
  *train_seconds = 0;
  if (fs::is_regular_file(map_path) && ReadText(key_path) == key) {
    auto cached = LoadMap(map_path.string());
    if (cached.ok()) return cached;
  }
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return IoError("cannot create '" + dir.string() + "': " + ec.message());
  Stopwatch watch;
  SCENELOC_ASSIGN_OR_RETURN(Map map, TrainPadded(data, padding, train, context, options.progress));
  *train_seconds = watch.Seconds();
  SCENELOC_RETURN_IF_ERROR(SaveMap(map, map_path.string()));
  std::ofstream(key_path, std::ios::binary | std::ios::trunc) << key;
  return map;
}

}  // namespace

StatusOr<SetResult> RunSetWithDistractors(const SuiteSet& set, const SuiteSettings& settings,
                                          const SuiteContext& context,
                                          const DistractorOptions& distractors) {
  if (context.cache_dir.empty()) return InvalidArgument("distractors need a cache folder");
  SetResult result;
  result.set = set;
  result.comparisons = false;
  SCENELOC_ASSIGN_OR_RETURN(const SetData data, LoadSet(set, settings.train.extractor, context));
  result.set.tour_dir = data.tour_dir;  // a generated set's: where it was rendered
  result.set.queries_dir = data.queries_dir;
  SCENELOC_ASSIGN_OR_RETURN(const Map map, PaddedMap(set, data, settings.train, context,
                                                     distractors, &result.train_seconds));
  result.locations = map.num_images();
  result.landmarks = map.num_landmarks();
  result.outcomes.resize(data.queries.size());
  for (size_t q = 0; q < data.queries.size(); ++q) {
    result.outcomes[q].name = data.query_names[q];
    result.outcomes[q].truth = data.truth[q];
  }
  SCENELOC_RETURN_IF_ERROR(
      RunOurs(data.queries, map, settings.match, context.threads, &result.outcomes));
  result.summary = Summarise(result.outcomes, /*with_baseline=*/false,
                             {settings.train.tolerance, settings.match.min_confidence});
  SuiteSet offroute = set;
  offroute.negative_dirs.clear();
  if (!distractors.offroute_dir.empty()) offroute.negative_dirs.push_back(distractors.offroute_dir);
  SCENELOC_RETURN_IF_ERROR(RunNegatives(offroute, map, settings.match, data, context, &result));
  SummariseSessions(map, settings, &result);
  result.shell = MapShell(map);
  return result;
}

}  // namespace sceneloc
