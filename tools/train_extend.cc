#include "tools/train_extend.h"

#include <cstdio>
#include <functional>
#include <memory>
#include <vector>

#include "common/map/map_io.h"
#include "common/training/extend.h"
#include "common/util/image_folder.h"
#include "common/util/progress_printer.h"
#include "common/util/timer.h"

namespace sceneloc {
namespace {

// Reading the map file and writing the extended one.
struct FileSeconds {
  double load_seconds = 0;
  double save_seconds = 0;
};

void PrintExtension(const ExtendSummary& s, const Map& before, const Map& after,
                    const ExtendArgs& args, double seconds, size_t bytes, const FileSeconds& io) {
  const Experience& e = after.experiences.back();
  std::printf("extended %s with '%s' (%s) in %.1f s -> %s\n", args.map_path.c_str(), e.name.c_str(),
              ExperienceKindName(e.kind), seconds, args.out_path.c_str());
  std::printf("  walk                 %zu frames\n", s.frames.size());
  if (e.kind == ExperienceKind::kRoute) {
    std::printf(
        "  aligned              %zu frames to a place of the route by the session, %zu "
        "more between them, %zu not\n",
        s.aligned, s.bridged, s.frames.size() - s.aligned - s.bridged);
    std::printf(
        "  recognised           %zu frames the map already knew (LOCALISED with %.0f+ "
        "inliers): they add nothing\n",
        s.recognised, s.recognised_inliers);
  }
  std::printf("  added                %zu images, %zu landmarks, %zu new places\n", s.added,
              s.landmarks_added, s.new_places);
  std::printf(
      "  map                  %d -> %d places, %d -> %d images, %d -> %d landmarks, "
      "%zu experiences\n",
      before.num_places(), after.num_places(), before.num_images(), after.num_images(),
      before.num_landmarks(), after.num_landmarks(), after.experiences.size());
  std::printf("  map file             %.2f MB\n", static_cast<double>(bytes) / 1e6);
  std::printf(
      "  time (s)             load %.1f, extract %.1f, align %.1f, train the walk %.1f, merge "
      "%.1f, save %.1f\n",
      io.load_seconds, s.walk.extract_seconds, s.align_seconds, s.train_seconds, s.merge_seconds,
      io.save_seconds);
}

// One row per walk frame: its place (and that place's name), how sure the session was,
// the single-frame answer, and whether it was recognised or added.
Status WriteFrames(const std::string& path, const std::vector<std::string>& names,
                   const ExtendSummary& s, const Map& map) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (f == nullptr) return IoError("cannot write '" + path + "'");
  std::fprintf(f,
               "frame,name,place,place_name,probability,bridged,single,single_confidence,"
               "single_inliers,recognised,added\n");
  for (size_t i = 0; i < s.frames.size(); ++i) {
    const WalkFrame& w = s.frames[i];
    std::fprintf(f, "%zu,%s,%d,%s,%.4f,%d,%d,%.4f,%d,%d,%d\n", i, names[i].c_str(), w.place,
                 w.place >= 0 ? map.PlaceName(w.place).c_str() : "", w.probability,
                 w.bridged ? 1 : 0, w.single, w.single_confidence, w.single_inliers,
                 w.recognised ? 1 : 0, w.added ? 1 : 0);
  }
  return std::fclose(f) == 0 ? Status::Ok() : IoError("cannot write '" + path + "'");
}

}  // namespace

int ExtendCommand(const ExtendArgs& args) {
  Stopwatch watch;
  MapFileInfo info;
  FileSeconds io;
  StatusOr<Map> map = LoadMap(args.map_path, &info);
  io.load_seconds = watch.Seconds();
  if (!map.ok()) {
    std::fprintf(stderr, "sceneloc-train: %s\n", map.status().message().c_str());
    return 1;
  }
  if (info.format_version != kMapFormatVersion) {
    std::fprintf(stderr,
                 "sceneloc-train: '%s' is of map format %u; only today's (%u) is extended: "
                 "rewrite it first with sceneloc-train --upgrade %s --out NEW\n",
                 args.map_path.c_str(), info.format_version, kMapFormatVersion,
                 args.map_path.c_str());
    return 1;
  }
  StatusOr<std::vector<std::string>> paths = ListImageFiles(args.walk_dir);
  if (!paths.ok()) {
    std::fprintf(stderr, "sceneloc-train: %s\n", paths.status().message().c_str());
    return 1;
  }
  auto spool = FeatureSpool::Create(args.spool_dir);
  if (!spool.ok()) {
    std::fprintf(stderr, "sceneloc-train: %s\n", spool.status().message().c_str());
    return 1;
  }
  ProgressPrinter progress;
  Stopwatch extract;
  const Map& m = *map;
  const Status extracted = ExtractToSpool(
      *paths, m.options.extractor, [&](int w, int h) { return m.QueryTarget(w, h); }, args.threads,
      std::ref(progress), spool->get());
  if (!extracted.ok()) {
    std::fprintf(stderr, "sceneloc-train: %s\n", extracted.message().c_str());
    return 1;
  }
  const double extract_seconds = extract.Seconds();
  std::vector<std::string> names;
  for (const std::string& path : *paths) names.push_back(FileName(path));
  ExtendOptions options;
  options.name = args.name.empty() ? FolderName(args.walk_dir) : args.name;
  options.source_dir = args.walk_dir;
  options.new_ground = args.new_ground;
  StatusOr<ExtendResult> result =
      ExtendMap(m, **spool, names, options, args.threads, std::ref(progress));
  if (!result.ok()) {
    std::fprintf(stderr, "sceneloc-train: %s\n", result.status().message().c_str());
    return 1;
  }
  result->summary.walk.extract_seconds = extract_seconds;
  MapFileInfo saved;
  Stopwatch save;
  const Status written = SaveMap(result->map, args.out_path, &saved);
  io.save_seconds = save.Seconds();
  if (const Status& s = written; !s.ok()) {
    std::fprintf(stderr, "sceneloc-train: %s\n", s.message().c_str());
    return 1;
  }
  if (!args.frames_csv.empty()) {
    if (const Status s = WriteFrames(args.frames_csv, names, result->summary, result->map);
        !s.ok()) {
      std::fprintf(stderr, "sceneloc-train: %s\n", s.message().c_str());
      return 1;
    }
  }
  PrintExtension(result->summary, m, result->map, args, watch.Seconds(),
                 kMapHeaderBytes + saved.payload_bytes, io);
  return 0;
}

}  // namespace sceneloc
