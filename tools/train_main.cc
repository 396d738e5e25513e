// sceneloc-train: turns a tour folder into a landmark map file, or adds a walk to one.
//   sceneloc-train --tour DIR --out FILE [--config configs/train.yaml] [--threads N]
//   sceneloc-train --extend MAP --tour DIR --out FILE [--new-ground] [--name NAME]
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <thread>

#include "common/config/config.h"
#include "common/map/map_io.h"
#include "common/training/trainer.h"
#include "common/util/progress_printer.h"
#include "common/util/timer.h"
#include "common/util/version.h"
#include "tools/train_extend.h"

namespace {

// Where the map is weak: the stretches of the tour whose frames verify against places
// elsewhere on the route (lookalikes.h).
void PrintLookAlikes(const sceneloc::TrainSummary& s) {
  constexpr size_t kShown = 8;
  if (s.lookalikes.empty()) return;
  const std::vector<sceneloc::LookAlikeStretch> stretches =
      sceneloc::LookAlikeStretches(s.lookalikes, sceneloc::kLookAlikeInliers);
  size_t frames = 0;
  for (const sceneloc::LookAlikeStretch& a : stretches) frames += a.last - a.first + 1;
  if (stretches.empty()) {
    std::printf(
        "  look-alikes          none: no place verifies against another more than %d frames away\n",
        sceneloc::kHeldOutFrames);
    return;
  }
  std::printf(
      "  look-alikes          %zu stretch%s (%zu places) verify against places more than %d "
      "frames away:\n",
      stretches.size(), stretches.size() == 1 ? "" : "es", frames, sceneloc::kHeldOutFrames);
  for (size_t i = 0; i < stretches.size() && i < kShown; ++i) {
    const sceneloc::LookAlikeStretch& a = stretches[i];
    const auto span = [](int first, int last) {
      return first == last ? std::to_string(first)
                           : std::to_string(first) + "-" + std::to_string(last);
    };
    std::printf("                       places %s look like %s (up to %.0f inliers above chance)\n",
                span(a.first, a.last).c_str(), span(a.rival_first, a.rival_last).c_str(), a.excess);
  }
  if (stretches.size() > kShown) {
    std::printf("                       ... and %zu more\n", stretches.size() - kShown);
  }
}

void PrintSummary(const sceneloc::TrainSummary& s, const std::string& out, double seconds,
                  size_t bytes) {
  std::printf("trained %s in %.1f s\n", out.c_str(), seconds);
  std::printf("  images               %zu, working frame %dx%d\n", s.images, s.frame_width,
              s.frame_height);
  std::printf("  features             %zu (%.0f per image)\n", s.features,
              static_cast<double>(s.features) / static_cast<double>(s.images));
  std::printf("  links                %zu candidate, %zu verified by RANSAC\n", s.candidate_links,
              s.verified_links);
  std::printf("  tracks (candidates)  %zu, mean length %.2f, max %zu\n", s.tracks,
              s.mean_track_length, s.max_track_length);
  if (s.coverage_landmarks > 0) {
    std::printf("  coverage             %zu single-view candidates for images with few tracks\n",
                s.coverage_landmarks);
  }
  std::printf("  landmarks kept       %zu of %zu (quality measured in %zu window%s)\n",
              s.landmarks_kept, s.landmarks_before_selection, s.quality_windows,
              s.quality_windows == 1 ? ", the whole tour" : "s");
  std::printf("  landmarks per image  mean %.1f, min %zu, max %zu\n", s.landmarks_per_image_mean,
              s.landmarks_per_image_min, s.landmarks_per_image_max);
  if (!s.images_without_landmarks.empty()) {
    std::string names;
    for (size_t i = 0; i < s.images_without_landmarks.size() && i < 5; ++i) {
      names += (i ? ", " : "") + s.images_without_landmarks[i];
    }
    if (s.images_without_landmarks.size() > 5) names += ", ...";
    std::printf(
        "  WARNING              %zu image(s) hold no landmark (%s): only their holistic "
        "descriptor can answer them\n",
        s.images_without_landmarks.size(), names.c_str());
  }
  std::printf("  map file             %.2f MB\n", static_cast<double>(bytes) / 1e6);
  if (s.spool_bytes > 0) {
    std::printf("  feature spool        %.2f GB on disk while training\n",
                static_cast<double>(s.spool_bytes) / 1e9);
  }
  PrintLookAlikes(s);
  std::printf(
      "  time (s)             extract %.1f, track %.1f, fuse %.1f, quality %.1f, "
      "select %.2f, co-occurrence %.1f, calibration %.1f, place index %.1f, look-alikes %.1f\n",
      s.extract_seconds, s.track_seconds, s.fuse_seconds, s.quality_seconds, s.select_seconds,
      s.cooccurrence_seconds, s.calibration_seconds, s.index_seconds, s.lookalike_seconds);
}

// Refuses an --out that cannot be written before any work is done: its folder must exist
// and be writable, and the path must not be a folder itself.
sceneloc::Status CheckOutput(const std::string& out_path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::is_directory(out_path, ec)) {
    return sceneloc::InvalidArgument("--out '" + out_path + "' is a folder; name the map file");
  }
  fs::path dir = fs::path(out_path).parent_path();
  if (dir.empty()) dir = ".";
  if (!fs::is_directory(dir, ec)) {
    return sceneloc::NotFound("--out: folder '" + dir.string() + "' does not exist");
  }
  if (::access(dir.c_str(), W_OK) != 0) {
    return sceneloc::IoError("--out: folder '" + dir.string() + "' is not writable");
  }
  return sceneloc::Status::Ok();
}

// Rewrites the map file `in` in today's format at `out`: a map of an older format loads (its
// arrays converted while read), but each load pays the conversion. Returns the exit code.
int Upgrade(const std::string& in, const std::string& out) {
  sceneloc::MapFileInfo before;
  auto map = sceneloc::LoadMap(in, &before);
  if (!map.ok()) {
    std::fprintf(stderr, "sceneloc-train: %s\n", map.status().message().c_str());
    return 1;
  }
  sceneloc::MapFileInfo after;
  if (const sceneloc::Status s = sceneloc::SaveMap(*map, out, &after); !s.ok()) {
    std::fprintf(stderr, "sceneloc-train: %s\n", s.message().c_str());
    return 1;
  }
  std::printf("%s: format %u, %.1f MB -> %s: format %u, %.1f MB (%d locations)\n", in.c_str(),
              before.format_version,
              static_cast<double>(sceneloc::kMapHeaderBytes + before.payload_bytes) / 1e6,
              out.c_str(), after.format_version,
              static_cast<double>(sceneloc::kMapHeaderBytes + after.payload_bytes) / 1e6,
              map->num_images());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"sceneloc-train: build a landmark map from a training tour"};
  app.set_version_flag("--version", std::string(sceneloc::Version()));
  std::string tour_dir, out_path, config_path, spool_dir, upgrade_path, extend_path, name;
  std::string frames_csv;
  bool new_ground = false;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  int eta = -1;
  bool print_config = false;
  app.add_option("--tour", tour_dir,
                 "folder of tour images, in tour order by file name (required)");
  app.add_option("--out", out_path, "map file to write (required)");
  app.add_option("--config", config_path, "training settings (YAML), e.g. configs/train.yaml");
  app.add_option("--eta", eta, "override selection.eta (landmarks per image; 0 = keep all)");
  app.add_option("--threads", threads, "worker threads")->check(CLI::Range(1, 256));
  app.add_option("--spool-dir", spool_dir,
                 "folder for the features while training, about 1 MB per tour image, removed "
                 "when done (default: the folder of --out)");
  app.add_option("--upgrade", upgrade_path,
                 "instead of training, rewrite this map file in today's format at --out (older "
                 "formats load too, converted on every load)");
  app.add_option("--extend", extend_path,
                 "instead of training, add the walk in --tour to this map, written at --out: "
                 "another experience of the route (aligned to its places), or new ground");
  app.add_flag("--new-ground", new_ground,
               "with --extend: the walk covers ground the map does not; each frame a new place");
  app.add_option("--name", name, "with --extend: the experience's name (default: the folder's)");
  app.add_option("--frames-csv", frames_csv,
                 "with --extend: write what became of each walk frame (its place, how sure, "
                 "recognised or added) as CSV");
  app.add_flag("--print-config", print_config,
               "print the settings in effect (defaults, --config, --eta) as a documented "
               "settings file, and exit");
  CLI11_PARSE(app, argc, argv);

  sceneloc::TrainOptions options;
  if (!config_path.empty()) {
    const sceneloc::Status s = sceneloc::LoadTrainOptions(config_path, &options);
    if (!s.ok()) {
      std::fprintf(stderr, "sceneloc-train: %s\n", s.message().c_str());
      return 2;
    }
  }
  if (eta >= 0) options.eta = eta;
  if (print_config) {
    std::fputs(sceneloc::DocumentedTrainSettings(options).c_str(), stdout);
    return 0;
  }
  if (!upgrade_path.empty()) {
    if (!tour_dir.empty() || out_path.empty()) {
      std::fprintf(stderr, "sceneloc-train: --upgrade takes --out and no --tour (see --help)\n");
      return 2;
    }
    if (const sceneloc::Status s = CheckOutput(out_path); !s.ok()) {
      std::fprintf(stderr, "sceneloc-train: %s\n", s.message().c_str());
      return 2;
    }
    return Upgrade(upgrade_path, out_path);
  }
  if (tour_dir.empty() || out_path.empty()) {
    std::fprintf(stderr, "sceneloc-train: --tour and --out are required (see --help)\n");
    return 2;
  }
  if (const sceneloc::Status s = CheckOutput(out_path); !s.ok()) {
    std::fprintf(stderr, "sceneloc-train: %s\n", s.message().c_str());
    return 2;
  }
  if (spool_dir.empty()) {
    spool_dir = std::filesystem::path(out_path).parent_path().string();
    if (spool_dir.empty()) spool_dir = ".";
  }
  if (!extend_path.empty()) {
    if (!config_path.empty() || eta >= 0) {
      std::fprintf(stderr,
                   "sceneloc-train: --extend trains the walk with the map's own settings; it "
                   "takes no --config or --eta\n");
      return 2;
    }
    return sceneloc::ExtendCommand(
        {extend_path, tour_dir, out_path, name, spool_dir, frames_csv, new_ground, threads});
  }
  if (new_ground || !name.empty() || !frames_csv.empty()) {
    std::fprintf(stderr,
                 "sceneloc-train: --new-ground, --name and --frames-csv go with --extend\n");
    return 2;
  }
  sceneloc::Stopwatch watch;
  sceneloc::ProgressPrinter progress;
  auto result =
      sceneloc::TrainFromFolder(tour_dir, options, threads, std::ref(progress), spool_dir);
  if (!result.ok()) {
    std::fprintf(stderr, "sceneloc-train: %s\n", result.status().message().c_str());
    return 1;
  }
  sceneloc::MapFileInfo info;
  const sceneloc::Status saved = sceneloc::SaveMap(result->map, out_path, &info);
  if (!saved.ok()) {
    std::fprintf(stderr, "sceneloc-train: %s\n", saved.message().c_str());
    return 1;
  }
  if (result->summary.mixed_size_images > 0) {
    std::fprintf(stderr,
                 "sceneloc-train: warning: %zu of %zu tour images differ in size from the first; "
                 "each was brought into the first image's working frame\n",
                 result->summary.mixed_size_images, result->summary.images);
  }
  PrintSummary(result->summary, out_path, watch.Seconds(),
               sceneloc::kMapHeaderBytes + info.payload_bytes);
  return 0;
}
