#include "common/training/trainer.h"

#include <algorithm>
#include <atomic>
#include <filesystem>

#include "common/training/calibration.h"
#include "common/training/candidate_chunks.h"
#include "common/training/cooccurrence.h"
#include "common/training/landmark_builder.h"
#include "common/training/place_index_builder.h"
#include "common/training/quality.h"
#include "common/training/selection.h"
#include "common/training/tracker.h"
#include "common/util/image_folder.h"
#include "common/util/mutex.h"
#include "common/util/thread_pool.h"
#include "common/util/timer.h"
#include "common/util/utc_time.h"
#include "common/util/version.h"

namespace sceneloc {
namespace {

// Images the link and extraction passes hold at a time (plus one): enough to keep every
// thread busy, few enough that a batch of full-size features stays around 100 MB.
constexpr size_t kBatchImages = 64;

void Report(const ProgressFn& progress, const char* stage, size_t done, size_t total) {
  if (progress) progress(stage, done, total);
}

// What one pass over the tour learns besides its features: the links between consecutive
// images, the working frame, and every image's holistic descriptor (which go into the map).
struct TourScan {
  TourLinks links;
  TrackingStats tracking;
  size_t features = 0;
  int frame_width = 0;
  int frame_height = 0;
  HolisticGrid holistic_grid;
  std::vector<float> holistic;  // image after image
};

// Every tour image must be in one frame width (ExtractFolder makes sure of it) and carry a
// holistic descriptor on one grid, or none at all.
Status CheckFrame(const FeatureSet& f, size_t image, const TourScan& scan) {
  if (f.image_width != scan.frame_width) {
    return InvalidArgument("tour image " + std::to_string(image) + " was extracted " +
                           std::to_string(f.image_width) + " pixels wide, the first " +
                           std::to_string(scan.frame_width));
  }
  if (f.holistic_grid != scan.holistic_grid ||
      f.holistic.size() != static_cast<size_t>(f.holistic_grid.size())) {
    return InvalidArgument("tour image " + std::to_string(image) +
                           " has a holistic descriptor unlike the first image's");
  }
  return Status::Ok();
}

// Reads the tour once, a batch at a time: checks every frame, keeps the holistic
// descriptors and links each image to the next (paper II-A), the pairs in parallel.
StatusOr<TourScan> ScanTour(const TourFeatures& tour, const TrainOptions& options, ThreadPool* pool,
                            const ProgressFn& progress) {
  const size_t n = tour.size();
  TourScan scan;
  scan.links.next.resize(n - 1);
  std::vector<TrackingStats> pair_stats(n - 1);
  for (size_t begin = 0; begin < n; begin += kBatchImages) {
    const size_t end = std::min(n, begin + kBatchImages);
    // One image past the batch, the second image of its last pair.
    SCENELOC_ASSIGN_OR_RETURN(const TourWindow window, tour.Window(begin, std::min(n, end + 1)));
    if (begin == 0) {
      scan.frame_width = window[0].image_width;
      scan.frame_height = window[0].image_height;
      scan.holistic_grid = window[0].holistic_grid;
    }
    for (size_t i = begin; i < end; ++i) {
      const FeatureSet& f = window[i];
      SCENELOC_RETURN_IF_ERROR(CheckFrame(f, i, scan));
      scan.links.feature_counts.push_back(f.size());
      scan.features += static_cast<size_t>(f.size());
      scan.holistic.insert(scan.holistic.end(), f.holistic.begin(), f.holistic.end());
    }
    const size_t pairs_end = std::min(end, n - 1);
    pool->ParallelFor(pairs_end - begin, 1, [&](size_t b, size_t e) {
      for (size_t i = begin + b; i < begin + e; ++i) {
        scan.links.next[i] = LinkImagePair(window[i], window[i + 1], options, &pair_stats[i]);
      }
    });
    Report(progress, "link", pairs_end, n - 1);
  }
  for (const TrackingStats& s : pair_stats) {
    scan.tracking.candidate_links += s.candidate_links;
    scan.tracking.verified_links += s.verified_links;
    scan.tracking.pairs_unverified += s.pairs_unverified;
  }
  return scan;
}

void SummariseTracks(const std::vector<CandidateChunk>& chunks, TrainSummary* s) {
  size_t total = 0;
  for (const CandidateChunk& c : chunks) {
    s->tracks += c.tracks.size();
    for (const Track& t : c.tracks) {
      total += t.size();
      s->max_track_length = std::max(s->max_track_length, t.size());
    }
  }
  s->mean_track_length = s->tracks == 0 ? 0.0 : static_cast<double>(total) / s->tracks;
}

void SummariseImages(const Map& map, TrainSummary* s) {
  s->landmarks_kept = static_cast<size_t>(map.num_landmarks());
  s->landmarks_per_image_min = SIZE_MAX;
  for (int l = 0; l < map.num_images(); ++l) {
    const size_t count = map.image_offsets[l + 1] - map.image_offsets[l];
    if (count == 0) s->images_without_landmarks.push_back(map.image_names[l]);
    s->landmarks_per_image_min = std::min(s->landmarks_per_image_min, count);
    s->landmarks_per_image_max = std::max(s->landmarks_per_image_max, count);
  }
  s->landmarks_per_image_mean =
      static_cast<double>(map.image_landmarks.size()) / std::max(1, map.num_images());
}

// Everything the chunk passes share.
struct ChunkContext {
  const TourFeatures& tour;
  const std::vector<std::string>& image_names;
  const TrainOptions& options;
  const TourScan& scan;
  ThreadPool* pool;
  const ProgressFn& progress;
};

// The first pass over the chunks: tops each up with its single-view candidates, fuses its
// candidates from its window and measures their quality Q there (paper IV, eq. 4).
// Returns Q of every candidate, in chunk order; numbers the chunks' candidates.
StatusOr<std::vector<float>> MeasureQuality(const ChunkContext& c, const TrackedFeatures& tracked,
                                            std::vector<CandidateChunk>* chunks, TrainSummary* s) {
  std::vector<float> quality;
  size_t images_done = 0, images_total = 0;
  for (const CandidateChunk& chunk : *chunks) images_total += chunk.window_end() - chunk.begin;
  for (CandidateChunk& chunk : *chunks) {
    // The window before the single-view candidates, which lie within [begin, end) anyway.
    SCENELOC_ASSIGN_OR_RETURN(const TourWindow window,
                              c.tour.Window(chunk.begin, chunk.window_end()));
    s->coverage_landmarks += AddSingleViewCandidates(window, tracked, c.options, &chunk);
    chunk.first_candidate = quality.size();
    if (chunk.tracks.empty()) continue;
    SCENELOC_ASSIGN_OR_RETURN(const Map candidates,
                              FuseCandidates(chunk.tracks, window, c.image_names,
                                             c.scan.frame_width, c.scan.frame_height, c.options));
    const std::vector<float> q =
        ComputeQuality(candidates, chunk.tracks, window, c.options.quality_s_min,
                       c.options.quality_fp_prior, c.pool, [&](size_t done, size_t) {
                         Report(c.progress, "quality", images_done + done, images_total);
                       });
    images_done += window.size();
    quality.insert(quality.end(), q.begin(), q.end());
  }
  if (c.options.min_track_length == 1) {
    // Every untracked feature is a track of its own: counted as tracks, not as coverage.
    const size_t singles = s->coverage_landmarks;
    s->mean_track_length =
        (s->mean_track_length * static_cast<double>(s->tracks) + static_cast<double>(singles)) /
        std::max<double>(1.0, static_cast<double>(s->tracks + singles));
    if (singles > 0) s->max_track_length = std::max<size_t>(s->max_track_length, 1);
    s->tracks += singles;
    s->coverage_landmarks = 0;
  }
  return quality;
}

// The candidates worth keeping (paper II-C): by quality Q, at most eta per image, at least
// q_min. Returns their indices, ascending.
StatusOr<std::vector<uint32_t>> SelectCandidates(const std::vector<CandidateChunk>& chunks,
                                                 const std::vector<float>& quality,
                                                 const TrainOptions& options, size_t num_images) {
  std::vector<std::vector<uint32_t>> landmark_images;
  landmark_images.reserve(quality.size());
  for (const CandidateChunk& chunk : chunks) {
    for (const Track& t : chunk.tracks) {
      std::vector<uint32_t> images;
      for (const TrackObservation& o : t) images.push_back(o.image);
      landmark_images.push_back(std::move(images));
    }
  }
  std::vector<uint32_t> keep = SelectLandmarks(
      landmark_images, quality, static_cast<int>(num_images), options.eta, options.q_min);
  if (keep.empty()) {
    return FailedPrecondition("no landmark reached q_min = " + std::to_string(options.q_min));
  }
  return keep;
}

// The second pass over the chunks: fuses the kept candidates of each again from its window
// into the map, with their quality.
Status FuseKept(const ChunkContext& c, const std::vector<CandidateChunk>& chunks,
                const std::vector<uint32_t>& keep, const std::vector<float>& quality, Map* map) {
  ReserveLandmarks(keep.size(), map);
  auto next = keep.begin();
  for (const CandidateChunk& chunk : chunks) {
    const size_t last = chunk.first_candidate + chunk.tracks.size();
    std::vector<Track> kept;
    std::vector<float> kept_quality;
    for (; next != keep.end() && *next < last; ++next) {
      kept.push_back(chunk.tracks[*next - chunk.first_candidate]);
      kept_quality.push_back(quality[*next]);
    }
    if (!kept.empty()) {
      size_t window_end = chunk.begin + 1;
      for (const Track& t : kept) window_end = std::max<size_t>(window_end, t.back().image + 1);
      SCENELOC_ASSIGN_OR_RETURN(const TourWindow window, c.tour.Window(chunk.begin, window_end));
      Map part;
      FuseLandmarks(kept, window, c.options, &part);
      part.quality = std::move(kept_quality);
      AppendLandmarks(part, map);
    }
    Report(c.progress, "fuse", chunk.end, c.tour.size());
  }
  return Status::Ok();
}

// Neighbours, image lists, provenance and calibration of the fused map; validated and
// finalised.
Status FinishMap(const TrainOptions& options, ThreadPool* pool, TrainSummary* s, Map* map) {
  Stopwatch watch;
  BuildNeighbours(options, map);
  s->cooccurrence_seconds = watch.Seconds();
  SummariseImages(*map, s);
  MapProvenance& p = map->provenance;
  p.created_utc = UtcNow();
  p.tool_version = std::string(Version());
  p.num_features = static_cast<uint32_t>(s->features);
  p.num_tracks = static_cast<uint32_t>(s->tracks);
  p.num_candidates = static_cast<uint32_t>(s->landmarks_before_selection);
  const auto n = static_cast<uint32_t>(map->num_images());
  map->experiences = {{"tour", "", p.created_utc, ExperienceKind::kTour, 0, n, n, {}}};
  watch.Reset();
  CalibrateMap(map, pool);
  map->experiences.front().calibration = map->calibration;
  s->calibration_seconds = watch.Seconds();
  watch.Reset();
  BuildPlaceIndex(map, pool);
  s->index_seconds = watch.Seconds();
  SCENELOC_RETURN_IF_ERROR(map->Validate());
  map->Finalize();
  return Status::Ok();
}

}  // namespace

std::string UtcNow() { return UtcText(std::chrono::system_clock::now()); }

StatusOr<std::vector<FeatureSet>> ExtractImages(const std::vector<std::string>& image_paths,
                                                const ExtractorOptions& options,
                                                const TargetFn& target, int threads,
                                                const ProgressFn& progress, size_t* mixed_sizes) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  const auto extractor = FeatureExtractor::Create(options);
  std::vector<FeatureSet> features(image_paths.size());
  std::vector<Status> errors(image_paths.size());
  std::vector<cv::Size> sizes(image_paths.size());
  std::atomic<size_t> done{0};
  Mutex progress_mutex;  // one progress() call at a time
  ThreadPool pool(threads);
  pool.ParallelFor(image_paths.size(), 1, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      auto image = ReadImageFile(image_paths[i]);
      if (!image.ok()) {
        errors[i] = image.status();
        continue;
      }
      sizes[i] = image->size();
      auto set = extractor->Extract(*image, target(image->cols, image->rows));
      if (!set.ok()) {
        errors[i] =
            Status(set.status().code(), "'" + image_paths[i] + "': " + set.status().message());
        continue;
      }
      features[i] = std::move(set).value();
      const size_t n = ++done;
      if (progress) {
        MutexLock lock(&progress_mutex);
        progress("extract", n, image_paths.size());
      }
    }
  });
  for (const Status& e : errors) SCENELOC_RETURN_IF_ERROR(e);
  if (mixed_sizes != nullptr) {
    *mixed_sizes = static_cast<size_t>(
        std::count_if(sizes.begin(), sizes.end(), [&](cv::Size s) { return s != sizes[0]; }));
  }
  return features;
}

namespace {

// The first image's size and the tour frame it gives.
struct TourFrame {
  cv::Size size;
  ExtractionTarget frame;
};

StatusOr<TourFrame> FirstFrame(const std::string& first_path, const ExtractorOptions& options) {
  SCENELOC_ASSIGN_OR_RETURN(const cv::Mat first, ReadImageFile(first_path));
  return TourFrame{first.size(), TourTarget(first.cols, first.rows, options)};
}

// Where the images of a tour are extracted: TourTarget for the first's size; others as
// queries into its frame, counted in `mixed` when it is not null.
TargetFn TourTargets(const TourFrame& first, std::atomic<size_t>* mixed) {
  return TargetFn([first, mixed](int width, int height) {
    if (width == first.size.width && height == first.size.height) return first.frame;
    if (mixed != nullptr) ++*mixed;
    return QueryTarget(width, height, first.frame.width, first.frame.holistic);
  });
}

}  // namespace

StatusOr<std::vector<FeatureSet>> ExtractFolder(const std::vector<std::string>& image_paths,
                                                const ExtractorOptions& options, int threads,
                                                const ProgressFn& progress, size_t* mixed_sizes) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  if (image_paths.empty()) return FailedPrecondition("no tour image to extract");
  SCENELOC_ASSIGN_OR_RETURN(const TourFrame first, FirstFrame(image_paths[0], options));
  return ExtractImages(image_paths, options, TourTargets(first, nullptr), threads, progress,
                       mixed_sizes);
}

Status ExtractToSpool(const std::vector<std::string>& image_paths, const ExtractorOptions& options,
                      const TargetFn& target, int threads, const ProgressFn& progress,
                      FeatureSpool* spool) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  const size_t batch = kBatchImages * static_cast<size_t>(std::max(1, threads));
  for (size_t begin = 0; begin < image_paths.size(); begin += batch) {
    const size_t end = std::min(image_paths.size(), begin + batch);
    const std::vector<std::string> paths(image_paths.begin() + static_cast<std::ptrdiff_t>(begin),
                                         image_paths.begin() + static_cast<std::ptrdiff_t>(end));
    const auto batch_progress = [&](const std::string& stage, size_t done, size_t) {
      Report(progress, stage.c_str(), begin + done, image_paths.size());
    };
    SCENELOC_ASSIGN_OR_RETURN(const std::vector<FeatureSet> features,
                              ExtractImages(paths, options, target, threads, batch_progress));
    for (const FeatureSet& f : features) SCENELOC_RETURN_IF_ERROR(spool->Append(f));
  }
  return Status::Ok();
}

Status ExtractToSpool(const std::vector<std::string>& image_paths, const ExtractorOptions& options,
                      int threads, const ProgressFn& progress, FeatureSpool* spool,
                      size_t* mixed_sizes) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  if (image_paths.empty()) return FailedPrecondition("no tour image to extract");
  SCENELOC_ASSIGN_OR_RETURN(const TourFrame first, FirstFrame(image_paths[0], options));
  std::atomic<size_t> mixed{0};
  SCENELOC_RETURN_IF_ERROR(
      ExtractToSpool(image_paths, options, TourTargets(first, &mixed), threads, progress, spool));
  if (mixed_sizes != nullptr) *mixed_sizes = mixed.load();
  return Status::Ok();
}

StatusOr<TrainResult> TrainFromTour(const TourFeatures& tour,
                                    const std::vector<std::string>& image_names,
                                    const TrainOptions& options, int threads,
                                    const ProgressFn& progress, bool lookalikes) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  if (tour.size() < 2) {
    return FailedPrecondition("a tour needs at least 2 images, got " + std::to_string(tour.size()));
  }
  if (image_names.size() != tour.size()) return InvalidArgument("one image name per tour image");
  TrainResult result;
  TrainSummary& s = result.summary;
  s.images = tour.size();
  ThreadPool pool(threads);

  Stopwatch watch;
  SCENELOC_ASSIGN_OR_RETURN(TourScan scan, ScanTour(tour, options, &pool, progress));
  s.features = scan.features;
  s.candidate_links = scan.tracking.candidate_links;
  s.verified_links = scan.tracking.verified_links;
  s.frame_width = scan.frame_width;
  s.frame_height = scan.frame_height;
  TrackedFeatures tracked;
  std::vector<CandidateChunk> chunks =
      PlanChunks(ChainTracks(scan.links), scan.links, options.min_track_length,
                 options.quality_window, &tracked);
  scan.links.next.clear();
  scan.links.next.shrink_to_fit();
  SummariseTracks(chunks, &s);
  s.quality_windows = chunks.size();
  s.track_seconds = watch.Seconds();

  watch.Reset();
  const ChunkContext context{tour, image_names, options, scan, &pool, progress};
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<float> quality,
                            MeasureQuality(context, tracked, &chunks, &s));
  if (quality.empty()) {
    return FailedPrecondition(
        "no feature could be tracked between consecutive tour images; "
        "are the images of one route, in order?");
  }
  s.landmarks_before_selection = quality.size();
  s.quality_seconds = watch.Seconds();

  watch.Reset();
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<uint32_t> keep,
                            SelectCandidates(chunks, quality, options, tour.size()));
  s.select_seconds = watch.Seconds();

  watch.Reset();
  Map& map = result.map;
  map.options = options;
  map.image_names = image_names;
  map.image_width = scan.frame_width;
  map.image_height = scan.frame_height;
  map.holistic_grid = scan.holistic_grid;
  map.holistic.resize(scan.holistic.size());
  std::transform(scan.holistic.begin(), scan.holistic.end(), map.holistic.begin(), UnitByte);
  scan.holistic.clear();
  scan.holistic.shrink_to_fit();
  SCENELOC_RETURN_IF_ERROR(FuseKept(context, chunks, keep, quality, &map));
  s.fuse_seconds = watch.Seconds();
  chunks.clear();
  SCENELOC_RETURN_IF_ERROR(FinishMap(options, &pool, &s, &map));
  if (!lookalikes) return result;

  watch.Reset();
  SCENELOC_ASSIGN_OR_RETURN(s.lookalikes,
                            MeasureLookAlikes(tour, map, &pool, [&](size_t done, size_t total) {
                              Report(progress, "look-alikes", done, total);
                            }));
  StoreLookAlikes(s.lookalikes, kLookAlikeInliers, &map);
  s.lookalike_seconds = watch.Seconds();
  return result;
}

StatusOr<TrainResult> TrainFromFeatures(const std::vector<FeatureSet>& tour,
                                        const std::vector<std::string>& image_names,
                                        const TrainOptions& options, int threads,
                                        const ProgressFn& progress) {
  return TrainFromTour(TourInMemory(tour), image_names, options, threads, progress);
}

StatusOr<TrainResult> TrainFromFolder(const std::string& tour_dir, const TrainOptions& options,
                                      int threads, const ProgressFn& progress,
                                      const std::string& spool_dir) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<std::string> paths, ListImageFiles(tour_dir));
  if (paths.size() < 2) {
    return FailedPrecondition("tour folder '" + tour_dir + "' holds " +
                              std::to_string(paths.size()) + " image; a tour needs at least 2");
  }
  std::error_code ec;
  const std::string dir =
      spool_dir.empty() ? std::filesystem::temp_directory_path(ec).string() : spool_dir;
  SCENELOC_ASSIGN_OR_RETURN(const std::unique_ptr<FeatureSpool> spool, FeatureSpool::Create(dir));
  Stopwatch watch;
  size_t mixed_sizes = 0;
  SCENELOC_RETURN_IF_ERROR(
      ExtractToSpool(paths, options.extractor, threads, progress, spool.get(), &mixed_sizes));
  const double extract_seconds = watch.Seconds();
  std::vector<std::string> names;
  for (const std::string& path : paths) names.push_back(FileName(path));
  SCENELOC_ASSIGN_OR_RETURN(TrainResult result,
                            TrainFromTour(*spool, names, options, threads, progress));
  result.summary.extract_seconds = extract_seconds;
  result.summary.mixed_size_images = mixed_sizes;
  result.summary.spool_bytes = spool->bytes();
  result.map.provenance.tour_dir = tour_dir;
  Experience& walk = result.map.experiences.front();
  walk.source_dir = tour_dir;
  walk.name = FolderName(tour_dir);
  return result;
}

}  // namespace sceneloc
