#include "common/training/trainer.h"

#include <algorithm>
#include <atomic>
#include <ctime>

#include "common/training/calibration.h"
#include "common/training/cooccurrence.h"
#include "common/training/landmark_builder.h"
#include "common/training/quality.h"
#include "common/training/selection.h"
#include "common/training/tracker.h"
#include "common/util/image_folder.h"
#include "common/util/mutex.h"
#include "common/util/thread_pool.h"
#include "common/util/timer.h"

namespace sceneloc {
namespace {

std::string UtcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buffer[32];
  std::strftime(buffer, sizeof(buffer), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buffer;
}

// A map holding only the landmarks in `keep` (ascending), with observations; quality
// copied, neighbours and image lists left for BuildNeighbours.
Map SubsetLandmarks(const Map& all, const std::vector<uint32_t>& keep) {
  Map out;
  out.options = all.options;
  out.provenance = all.provenance;
  out.image_names = all.image_names;
  out.image_width = all.image_width;
  out.image_height = all.image_height;
  out.holistic_grid = all.holistic_grid;
  out.holistic = all.holistic;
  const auto n = static_cast<Eigen::Index>(keep.size());
  out.local_mean.resize(n, kDescriptorSize);
  out.context_mean.resize(n, kDescriptorSize);
  out.context_dmax.resize(n, kNumHistograms);
  out.context_var.resize(n, kNumHistograms);
  out.observation_offsets.assign(1, 0);
  for (Eigen::Index k = 0; k < n; ++k) {
    const uint32_t g = keep[static_cast<size_t>(k)];
    out.local_mean.row(k) = all.local_mean.row(g);
    out.context_mean.row(k) = all.context_mean.row(g);
    out.context_dmax.row(k) = all.context_dmax.row(g);
    out.context_var.row(k) = all.context_var.row(g);
    out.local_dmax.push_back(all.local_dmax[g]);
    out.local_var.push_back(all.local_var[g]);
    out.mean_x.push_back(all.mean_x[g]);
    out.mean_y.push_back(all.mean_y[g]);
    out.quality.push_back(all.quality[g]);
    for (uint32_t o = all.observation_offsets[g]; o < all.observation_offsets[g + 1]; ++o) {
      out.observation_image.push_back(all.observation_image[o]);
      out.observation_x.push_back(all.observation_x[o]);
      out.observation_y.push_back(all.observation_y[o]);
      out.observation_size.push_back(all.observation_size[o]);
      out.observation_angle.push_back(all.observation_angle[o]);
    }
    out.observation_offsets.push_back(static_cast<uint32_t>(out.observation_image.size()));
  }
  return out;
}

// Every tour image must be in one frame width (ExtractFolder makes sure of it) and carry a
// holistic descriptor on one grid, or none at all.
Status CheckFrames(const std::vector<FeatureSet>& tour) {
  for (size_t i = 1; i < tour.size(); ++i) {
    if (tour[i].image_width != tour[0].image_width) {
      return InvalidArgument("tour image " + std::to_string(i) + " was extracted " +
                             std::to_string(tour[i].image_width) + " pixels wide, the first " +
                             std::to_string(tour[0].image_width));
    }
    if (tour[i].holistic_grid != tour[0].holistic_grid ||
        tour[i].holistic.size() != static_cast<size_t>(tour[i].holistic_grid.size())) {
      return InvalidArgument("tour image " + std::to_string(i) +
                             " has a holistic descriptor unlike the first image's");
    }
  }
  return Status::Ok();
}

// The tour's holistic descriptors, image after image, into the map.
void CopyHolistic(const std::vector<FeatureSet>& tour, Map* map) {
  map->holistic_grid = tour.front().holistic_grid;
  map->holistic.clear();
  if (map->holistic_grid.empty()) return;
  map->holistic.reserve(tour.size() * static_cast<size_t>(map->holistic_grid.size()));
  for (const FeatureSet& f : tour)
    map->holistic.insert(map->holistic.end(), f.holistic.begin(), f.holistic.end());
}

// Drops tracks shorter than `min_length`; with min_length 1, adds every feature that no
// track holds as a track of its own (a single-view landmark).
std::vector<Track> ApplyMinTrackLength(std::vector<Track> tracks,
                                       const std::vector<FeatureSet>& tour, int min_length) {
  if (min_length == 1) {
    std::vector<std::vector<bool>> tracked(tour.size());
    for (size_t i = 0; i < tour.size(); ++i) tracked[i].assign(tour[i].keypoints.size(), false);
    for (const Track& t : tracks) {
      for (const TrackObservation& o : t) tracked[o.image][o.feature] = true;
    }
    for (size_t i = 0; i < tour.size(); ++i) {
      for (size_t f = 0; f < tracked[i].size(); ++f) {
        if (!tracked[i][f]) tracks.push_back({{uint32_t(i), uint32_t(f)}});
      }
    }
    return tracks;
  }
  tracks.erase(
      std::remove_if(tracks.begin(), tracks.end(),
                     [&](const Track& t) { return static_cast<int>(t.size()) < min_length; }),
      tracks.end());
  return tracks;
}

// Coverage: every tour image with fewer than `min_per_image` candidates gets single-view
// candidates from its untracked features, strongest response first, until it has that many
// (or runs out of features).
size_t AddCoverageTracks(const std::vector<FeatureSet>& tour, int min_per_image,
                         std::vector<Track>* tracks) {
  if (min_per_image <= 0) return 0;
  std::vector<std::vector<bool>> tracked(tour.size());
  std::vector<int> count(tour.size(), 0);
  for (size_t i = 0; i < tour.size(); ++i) tracked[i].assign(tour[i].keypoints.size(), false);
  for (const Track& t : *tracks) {
    for (const TrackObservation& o : t) {
      tracked[o.image][o.feature] = true;
      ++count[o.image];
    }
  }
  size_t added = 0;
  for (size_t i = 0; i < tour.size(); ++i) {
    std::vector<uint32_t> free;
    for (uint32_t f = 0; f < tracked[i].size(); ++f) {
      if (!tracked[i][f]) free.push_back(f);
    }
    const size_t wanted = static_cast<size_t>(std::max(0, min_per_image - count[i]));
    const size_t take = std::min(wanted, free.size());
    std::partial_sort(free.begin(), free.begin() + static_cast<std::ptrdiff_t>(take), free.end(),
                      [&](uint32_t a, uint32_t b) {
                        return tour[i].keypoints[a].response > tour[i].keypoints[b].response;
                      });
    for (size_t k = 0; k < take; ++k) tracks->push_back({{uint32_t(i), free[k]}});
    added += take;
  }
  return added;
}

void SummariseTracks(const std::vector<Track>& tracks, TrainSummary* s) {
  s->tracks = tracks.size();
  size_t total = 0;
  for (const Track& t : tracks) {
    total += t.size();
    s->max_track_length = std::max(s->max_track_length, t.size());
  }
  s->mean_track_length = tracks.empty() ? 0.0 : static_cast<double>(total) / tracks.size();
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

// The tracks the landmarks come from: tracked between images, kept by length and topped
// up for coverage. Fills the tracking figures of `s`.
StatusOr<std::vector<Track>> TrackLandmarks(const std::vector<FeatureSet>& tour,
                                            const TrainOptions& options, ThreadPool* pool,
                                            const ProgressFn& progress, TrainSummary* s) {
  Stopwatch watch;
  TrackingStats tracking;
  std::vector<Track> tracks = ApplyMinTrackLength(BuildTracks(tour, options, pool, &tracking), tour,
                                                  options.min_track_length);
  s->candidate_links = tracking.candidate_links;
  s->verified_links = tracking.verified_links;
  SummariseTracks(tracks, s);
  s->coverage_landmarks = AddCoverageTracks(tour, options.min_landmarks_per_image, &tracks);
  s->track_seconds = watch.Seconds();
  if (progress) progress("track", tour.size() - 1, tour.size() - 1);
  if (tracks.empty()) {
    return FailedPrecondition(
        "no feature could be tracked between consecutive tour images; "
        "are the images of one route, in order?");
  }
  return tracks;
}

// The candidate map: one landmark fused from each track, with its image lists but no
// neighbours yet; validated and finalised.
StatusOr<Map> FuseCandidates(const std::vector<Track>& tracks, const std::vector<FeatureSet>& tour,
                             const std::vector<std::string>& image_names,
                             const TrainOptions& options, TrainSummary* s) {
  Stopwatch watch;
  Map candidates;
  candidates.options = options;
  candidates.image_names = image_names;
  candidates.image_width = tour.front().image_width;
  candidates.image_height = tour.front().image_height;
  s->frame_width = candidates.image_width;
  s->frame_height = candidates.image_height;
  CopyHolistic(tour, &candidates);
  FuseLandmarks(tracks, tour, options, &candidates);
  BuildImageLists(&candidates);
  candidates.neighbour_offsets.assign(tracks.size() + 1, 0);
  SCENELOC_RETURN_IF_ERROR(candidates.Validate());
  candidates.Finalize();
  s->landmarks_before_selection = tracks.size();
  s->fuse_seconds = watch.Seconds();
  return candidates;
}

// The candidates worth keeping (paper II-C): by quality Q, at most eta per image, at least
// q_min. Fills candidates->quality on the way.
StatusOr<std::vector<uint32_t>> SelectCandidates(const std::vector<Track>& tracks,
                                                 const std::vector<FeatureSet>& tour,
                                                 const TrainOptions& options, ThreadPool* pool,
                                                 const ProgressFn& progress, Map* candidates,
                                                 TrainSummary* s) {
  Stopwatch watch;
  candidates->quality =
      ComputeQuality(*candidates, tracks, tour, options.quality_s_min, options.quality_fp_prior,
                     pool, [&](size_t done, size_t total) {
                       if (progress) progress("quality", done, total);
                     });
  s->quality_seconds = watch.Seconds();

  watch.Reset();
  std::vector<std::vector<uint32_t>> landmark_images(tracks.size());
  for (size_t t = 0; t < tracks.size(); ++t) {
    for (const TrackObservation& o : tracks[t]) landmark_images[t].push_back(o.image);
  }
  const std::vector<uint32_t> keep =
      SelectLandmarks(landmark_images, candidates->quality, static_cast<int>(tour.size()),
                      options.eta, options.q_min);
  s->select_seconds = watch.Seconds();
  if (keep.empty()) {
    return FailedPrecondition("no landmark reached q_min = " + std::to_string(options.q_min));
  }
  return keep;
}

// The map of the kept landmarks: their neighbours, provenance and calibration; validated
// and finalised.
StatusOr<Map> BuildFinalMap(const Map& candidates, const std::vector<uint32_t>& keep,
                            const TrainOptions& options, ThreadPool* pool, TrainSummary* s) {
  Stopwatch watch;
  Map map = SubsetLandmarks(candidates, keep);
  BuildNeighbours(options, &map);
  s->cooccurrence_seconds = watch.Seconds();
  SummariseImages(map, s);

  MapProvenance& p = map.provenance;
  p.created_utc = UtcNow();
  p.tool_version = "0.1.0";
  p.num_features = static_cast<uint32_t>(s->features);
  p.num_tracks = static_cast<uint32_t>(s->tracks);
  p.num_candidates = static_cast<uint32_t>(s->landmarks_before_selection);
  watch.Reset();
  CalibrateMap(&map, pool);
  s->calibration_seconds = watch.Seconds();
  SCENELOC_RETURN_IF_ERROR(map.Validate());
  map.Finalize();
  return map;
}

}  // namespace

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

StatusOr<std::vector<FeatureSet>> ExtractFolder(const std::vector<std::string>& image_paths,
                                                const ExtractorOptions& options, int threads,
                                                const ProgressFn& progress, size_t* mixed_sizes) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  if (image_paths.empty()) return FailedPrecondition("no tour image to extract");
  SCENELOC_ASSIGN_OR_RETURN(const cv::Mat first, ReadImageFile(image_paths[0]));
  const ExtractionTarget frame = TourTarget(first.cols, first.rows, options);
  const auto target = [&](int width, int height) {
    if (width == first.cols && height == first.rows) return frame;
    return QueryTarget(width, height, frame.width, frame.holistic);
  };
  return ExtractImages(image_paths, options, target, threads, progress, mixed_sizes);
}

StatusOr<TrainResult> TrainFromFeatures(const std::vector<FeatureSet>& tour,
                                        const std::vector<std::string>& image_names,
                                        const TrainOptions& options, int threads,
                                        const ProgressFn& progress) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  if (tour.size() < 2) {
    return FailedPrecondition("a tour needs at least 2 images, got " + std::to_string(tour.size()));
  }
  if (image_names.size() != tour.size()) return InvalidArgument("one image name per tour image");
  TrainResult result;
  TrainSummary& s = result.summary;
  s.images = tour.size();
  for (const FeatureSet& f : tour) s.features += static_cast<size_t>(f.size());
  ThreadPool pool(threads);
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<Track> tracks,
                            TrackLandmarks(tour, options, &pool, progress, &s));
  SCENELOC_RETURN_IF_ERROR(CheckFrames(tour));
  SCENELOC_ASSIGN_OR_RETURN(Map candidates, FuseCandidates(tracks, tour, image_names, options, &s));
  SCENELOC_ASSIGN_OR_RETURN(
      const std::vector<uint32_t> keep,
      SelectCandidates(tracks, tour, options, &pool, progress, &candidates, &s));
  SCENELOC_ASSIGN_OR_RETURN(result.map, BuildFinalMap(candidates, keep, options, &pool, &s));
  return result;
}

StatusOr<TrainResult> TrainFromFolder(const std::string& tour_dir, const TrainOptions& options,
                                      int threads, const ProgressFn& progress) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<std::string> paths, ListImageFiles(tour_dir));
  if (paths.size() < 2) {
    return FailedPrecondition("tour folder '" + tour_dir + "' holds " +
                              std::to_string(paths.size()) + " image; a tour needs at least 2");
  }
  Stopwatch watch;
  size_t mixed_sizes = 0;
  SCENELOC_ASSIGN_OR_RETURN(
      const std::vector<FeatureSet> tour,
      ExtractFolder(paths, options.extractor, threads, progress, &mixed_sizes));
  const double extract_seconds = watch.Seconds();
  std::vector<std::string> names;
  for (const std::string& path : paths) names.push_back(FileName(path));
  SCENELOC_ASSIGN_OR_RETURN(TrainResult result,
                            TrainFromFeatures(tour, names, options, threads, progress));
  result.summary.extract_seconds = extract_seconds;
  result.summary.mixed_size_images = mixed_sizes;
  result.map.provenance.tour_dir = tour_dir;
  return result;
}

}  // namespace sceneloc
