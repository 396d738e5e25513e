#include "common/training/extend.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>

#include "common/features/holistic.h"
#include "common/map/place_index.h"
#include "common/matching/sequence_filter.h"
#include "common/training/calibration.h"
#include "common/util/thread_pool.h"
#include "common/util/timer.h"

namespace sceneloc {
namespace {

// One session's pass over the walk in `order`: each frame's answer.
std::vector<SequenceAnswer> Pass(const Map& map, const MatchOptions& match,
                                 const std::vector<FrameEvidence>& evidence,
                                 const std::vector<size_t>& order) {
  const SequenceFilter filter(map, match.sequence);
  SequenceState state;
  std::vector<SequenceAnswer> answers(evidence.size());
  for (const size_t i : order) answers[i] = filter.Update(evidence[i], &state);
  return answers;
}

// Frames the session did not place, between two it did, are placed along the walk at the
// pace between those two (a robot's pace changes little over a few frames; the session may
// lose confidence there while its evidence is weak, as at night); up to kMaxBridge frames
// beyond the first or last placed frame take the pace of the nearest two. Gaps longer than
// kMaxBridge frames, or whose pace is implausible, stay unplaced.
void BridgeGaps(int num_places, std::vector<WalkFrame>* frames) {
  constexpr int kMaxBridge = 10;
  constexpr double kMaxPace = 4;  // places per frame
  std::vector<int> anchors;
  for (size_t i = 0; i < frames->size(); ++i) {
    if ((*frames)[i].place >= 0) anchors.push_back(static_cast<int>(i));
  }
  if (anchors.size() < 2) return;
  const auto place_at = [&](int i0, int i1, int i) {
    const double p0 = (*frames)[i0].place, p1 = (*frames)[i1].place;
    return static_cast<int>(std::lround(p0 + (p1 - p0) * (i - i0) / double(i1 - i0)));
  };
  const auto bridge = [&](int i, int place) {
    if (place < 0 || place >= num_places) return;
    WalkFrame& f = (*frames)[static_cast<size_t>(i)];
    f.place = place;
    f.bridged = true;
  };
  for (size_t a = 0; a + 1 < anchors.size(); ++a) {
    const int i0 = anchors[a], i1 = anchors[a + 1];
    const double pace = std::abs((*frames)[i1].place - (*frames)[i0].place) / double(i1 - i0);
    if (i1 - i0 - 1 > kMaxBridge || pace > kMaxPace) continue;
    for (int i = i0 + 1; i < i1; ++i) bridge(i, place_at(i0, i1, i));
  }
  const int n = static_cast<int>(frames->size());
  const int first = anchors[0], second = anchors[1];
  const int last = anchors.back(), before = anchors[anchors.size() - 2];
  for (int i = std::max(0, first - kMaxBridge); i < first; ++i) {
    bridge(i, place_at(first, second, i));
  }
  for (int i = last + 1; i < std::min(n, last + 1 + kMaxBridge); ++i) {
    bridge(i, place_at(before, last, i));
  }
}

// Localises every frame of the walk against the map, then follows it as a session both
// ways: a session needs a few frames to lock on, so the frames a forward pass meets first
// are the ones a backward pass meets last. Each frame takes the more probable LOCALISED
// answer of the two.
StatusOr<std::vector<WalkFrame>> AlignWalk(const Map& map, const TourFeatures& walk,
                                           const ExtendOptions& options, double recognised_inliers,
                                           ThreadPool* pool, const ProgressFn& progress) {
  const size_t n = walk.size();
  std::vector<FrameEvidence> evidence(n);
  std::vector<WalkFrame> frames(n);
  constexpr size_t kWindow = 16;
  for (size_t begin = 0; begin < n; begin += kWindow) {
    const size_t end = std::min(n, begin + kWindow);
    SCENELOC_ASSIGN_OR_RETURN(const TourWindow window, walk.Window(begin, end));
    // A frame per thread: a whole query keeps a thread busier than its scoring split up.
    std::vector<Status> failed(end - begin);
    pool->ParallelFor(end - begin, 1, [&](size_t from, size_t to) {
      for (size_t i = begin + from; i < begin + to; ++i) {
        StatusOr<LocaliseResult> r = Localise(window[i], map, options.match, nullptr);
        if (!r.ok()) {
          failed[i - begin] = r.status();
          continue;
        }
        if (!r->ranked.empty()) {
          frames[i].single = r->ranked[0].index;
          frames[i].single_confidence = r->decision == Decision::kLocalised ? r->confidence : 0.0;
          frames[i].single_inliers = std::max(0, r->ranked[0].inliers);
        }
        evidence[i] = EvidenceOf(*r, map, options.match);
      }
    });
    for (const Status& status : failed) SCENELOC_RETURN_IF_ERROR(status);
    if (progress) progress("align", end, n);
  }
  std::vector<size_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = i;
  const std::vector<SequenceAnswer> forward = Pass(map, options.match, evidence, order);
  std::reverse(order.begin(), order.end());
  const std::vector<SequenceAnswer> backward = Pass(map, options.match, evidence, order);
  const int tolerance = map.options.tolerance;
  for (size_t i = 0; i < n; ++i) {
    WalkFrame& f = frames[i];
    for (const SequenceAnswer* a : {&forward[i], &backward[i]}) {
      if (a->decision == Decision::kLocalised && a->probability > f.probability) {
        f.place = a->location;
        f.probability = a->probability;
      }
    }
    f.recognised = f.place >= 0 && f.single_confidence >= options.recognised_confidence &&
                   f.single_inliers >= recognised_inliers &&
                   std::abs(f.single - f.place) <= tolerance;
  }
  BridgeGaps(map.num_places(), &frames);
  return frames;
}

// The walk's images that are added, in walk order, and the place each shows.
struct Added {
  std::vector<uint32_t> frames;  // walk frames
  std::vector<uint32_t> places;
};

// Appends the kept images of `walk_map` (trained from the whole walk, frame i its image i)
// and their landmarks to `map`: a landmark is kept when some kept image selected it, with
// its observations in kept images only and its neighbours among kept landmarks only.
void AppendImages(const Map& walk_map, const Added& added, Map* map, size_t* landmarks_added) {
  const uint32_t first_image = static_cast<uint32_t>(map->num_images());
  const uint32_t first_landmark = static_cast<uint32_t>(map->num_landmarks());
  const size_t walk_images = static_cast<size_t>(walk_map.num_images());
  std::vector<int64_t> image_to(walk_images, -1);
  for (size_t k = 0; k < added.frames.size(); ++k) image_to[added.frames[k]] = int64_t(k);
  // Landmarks selected by a kept image, in order of first use.
  std::vector<int64_t> landmark_to(static_cast<size_t>(walk_map.num_landmarks()), -1);
  std::vector<uint32_t> kept;
  for (const uint32_t frame : added.frames) {
    for (uint32_t k = walk_map.image_offsets[frame]; k < walk_map.image_offsets[frame + 1]; ++k) {
      const uint32_t g = walk_map.image_landmarks[k];
      if (landmark_to[g] < 0) {
        landmark_to[g] = static_cast<int64_t>(kept.size());
        kept.push_back(g);
      }
    }
  }
  *landmarks_added = kept.size();
  // Images: names, places, holistic descriptors, G_l.
  const size_t cells = static_cast<size_t>(walk_map.holistic_grid.size());
  if (map->image_place.empty()) {
    for (uint32_t i = 0; i < first_image; ++i) map->image_place.push_back(i);
  }
  for (size_t k = 0; k < added.frames.size(); ++k) {
    const uint32_t frame = added.frames[k];
    map->image_names.push_back(walk_map.image_names[frame]);
    map->image_place.push_back(added.places[k]);
    if (map->has_holistic()) {
      const uint8_t* h = walk_map.holistic_of(static_cast<int>(frame));
      map->holistic.insert(map->holistic.end(), h, h + cells);
    }
    for (uint32_t j = walk_map.image_offsets[frame]; j < walk_map.image_offsets[frame + 1]; ++j) {
      map->image_landmarks.push_back(first_landmark +
                                     uint32_t(landmark_to[walk_map.image_landmarks[j]]));
    }
    map->image_offsets.push_back(static_cast<uint32_t>(map->image_landmarks.size()));
  }
  // Landmarks: descriptors and their spreads, quality, observations, neighbours.
  const Eigen::Index old_rows = map->local_mean.rows(), rows = old_rows + Eigen::Index(kept.size());
  map->local_mean.conservativeResize(rows, Eigen::NoChange);
  map->context_mean.conservativeResize(rows, Eigen::NoChange);
  map->context_dmax.conservativeResize(rows, Eigen::NoChange);
  map->context_var.conservativeResize(rows, Eigen::NoChange);
  for (size_t k = 0; k < kept.size(); ++k) {
    const uint32_t g = kept[k];
    const Eigen::Index row = old_rows + Eigen::Index(k);
    map->local_mean.row(row) = walk_map.local_mean.row(g);
    map->context_mean.row(row) = walk_map.context_mean.row(g);
    map->context_dmax.row(row) = walk_map.context_dmax.row(g);
    map->context_var.row(row) = walk_map.context_var.row(g);
    map->local_dmax.push_back(walk_map.local_dmax[g]);
    map->local_var.push_back(walk_map.local_var[g]);
    map->quality.push_back(walk_map.quality[g]);
    for (uint32_t o = walk_map.observation_offsets[g]; o < walk_map.observation_offsets[g + 1];
         ++o) {
      const int64_t image = image_to[walk_map.observation_image[o]];
      if (image < 0) continue;
      map->observation_image.push_back(first_image + static_cast<uint32_t>(image));
      map->observations.push_back(walk_map.observations[o]);
    }
    map->observation_offsets.push_back(static_cast<uint32_t>(map->observation_image.size()));
    for (uint32_t j = walk_map.neighbour_offsets[g]; j < walk_map.neighbour_offsets[g + 1]; ++j) {
      PackedNeighbour nb = walk_map.neighbours[j];
      const int64_t to = landmark_to[nb.landmark];
      if (to < 0) continue;
      nb.landmark = first_landmark + static_cast<uint32_t>(to);
      map->neighbours.push_back(nb);
    }
    map->neighbour_offsets.push_back(static_cast<uint32_t>(map->neighbours.size()));
  }
}

// The place index of a map that has one, kept current: the added landmarks take their words
// from the map's vocabulary and the added images' cells their codes from its codebook (neither
// is learnt again: a walk is a small part of the map, and the cost stays the walk's).
void ExtendPlaceIndex(size_t first_landmark, size_t first_image, ThreadPool* pool, Map* map) {
  PlaceIndex& index = map->place_index;
  if (index.empty()) return;
  const Eigen::Index rows = map->local_mean.rows() - Eigen::Index(first_landmark);
  if (rows > 0) {
    const DescriptorMatrix means = map->local_mean.bottomRows(rows).cast<float>() * (1.0f / 255.0f);
    const std::vector<uint32_t> words = AssignWords(index.vocabulary, means);
    index.landmark_word.insert(index.landmark_word.end(), words.begin(), words.end());
  }
  if (map->has_holistic() && !index.holistic.empty()) {
    const size_t cells = static_cast<size_t>(map->holistic_grid.cells());
    const size_t count = (static_cast<size_t>(map->num_images()) - first_image) * cells;
    const std::vector<uint8_t> codes =
        CodeCells(map->holistic, first_image * cells, count, index.holistic, pool);
    index.holistic.codes.insert(index.holistic.codes.end(), codes.begin(), codes.end());
  }
}

Status CheckWalkFrame(const Map& map, const TourFeatures& walk) {
  SCENELOC_ASSIGN_OR_RETURN(const TourWindow first, walk.Window(0, 1));
  if (first[0].image_width != map.image_width) {
    return FailedPrecondition("the walk's frames are " + std::to_string(first[0].image_width) +
                              " pixels wide, the map's working frame " +
                              std::to_string(map.image_width) +
                              ": extract them with the map's QueryTarget");
  }
  return Status::Ok();
}

}  // namespace

StatusOr<ExtendResult> ExtendMap(const Map& map, const TourFeatures& walk,
                                 const std::vector<std::string>& names,
                                 const ExtendOptions& options, int threads,
                                 const ProgressFn& progress) {
  const size_t n = walk.size();
  if (n < 2) return FailedPrecondition("a walk needs at least 2 frames, got " + std::to_string(n));
  if (names.size() != n) return InvalidArgument("one name per walk frame");
  SCENELOC_RETURN_IF_ERROR(CheckWalkFrame(map, walk));
  ThreadPool pool(threads);
  ExtendResult result;
  ExtendSummary& s = result.summary;

  // The walk as a tour of its own: its tracks need its consecutive frames, all of them.
  Stopwatch watch;
  TrainOptions walk_options = map.options;
  walk_options.place_index_min_locations = 0;  // the map's index takes its landmarks
  SCENELOC_ASSIGN_OR_RETURN(TrainResult trained,
                            TrainFromTour(walk, names, walk_options, threads, progress,
                                          /*lookalikes=*/false));
  s.walk = trained.summary;
  s.train_seconds = watch.Seconds();
  // How well the walk explains itself: verified links between consecutive frames.
  const double own_links = static_cast<double>(trained.summary.verified_links) /
                           static_cast<double>(std::max<size_t>(1, n - 1));

  watch.Reset();
  Added added;
  if (options.new_ground) {
    s.frames.assign(n, WalkFrame());
    for (size_t i = 0; i < n; ++i) {
      s.frames[i].place = map.num_places() + static_cast<int>(i);
      s.frames[i].added = true;
      added.frames.push_back(static_cast<uint32_t>(i));
      added.places.push_back(static_cast<uint32_t>(s.frames[i].place));
    }
    s.new_places = n;
  } else {
    SCENELOC_ASSIGN_OR_RETURN(
        s.frames, AlignWalk(map, walk, options, options.recognised_inlier_share * own_links, &pool,
                            progress));
    for (size_t i = 0; i < n; ++i) {
      WalkFrame& f = s.frames[i];
      if (f.place < 0) continue;
      if (f.bridged) {
        ++s.bridged;
      } else {
        ++s.aligned;
      }
      if (f.recognised) {
        ++s.recognised;
        continue;
      }
      f.added = true;
      added.frames.push_back(static_cast<uint32_t>(i));
      added.places.push_back(static_cast<uint32_t>(f.place));
    }
    const double share = static_cast<double>(s.aligned) / static_cast<double>(n);
    if (share < options.min_aligned_share) {
      char text[64];
      std::snprintf(text, sizeof text, "%.0f%%", 100 * share);
      return FailedPrecondition(
          "the walk matches the map in " + std::to_string(s.aligned) + " of its " +
          std::to_string(n) + " frames (" + text + "; at least " +
          std::to_string(static_cast<int>(std::lround(100 * options.min_aligned_share))) +
          "% are needed to add it as another experience of the route): is it of this map's "
          "route? Ground the map does not cover can be added as new ground");
    }
  }
  s.added = added.frames.size();
  s.align_seconds = watch.Seconds();
  s.recognised_inliers = options.recognised_inlier_share * own_links;
  if (added.frames.empty()) {
    return FailedPrecondition("the map already recognises every frame of the walk (" +
                              std::to_string(s.recognised) + " of " + std::to_string(n) +
                              "): nothing to add");
  }

  watch.Reset();
  Map& out = result.map;
  out = map;
  const size_t first_landmark = static_cast<size_t>(out.num_landmarks());
  const size_t first_image = static_cast<size_t>(out.num_images());
  if (out.experiences.empty()) {
    const auto images = static_cast<uint32_t>(out.num_images());
    Experience tour;
    tour.name = "tour";
    tour.source_dir = out.provenance.tour_dir;
    tour.created_utc = out.provenance.created_utc;
    tour.num_images = tour.walk_frames = images;
    tour.calibration = map.calibration;  // the same images, measured the same way
    out.experiences.push_back(tour);
  }
  Experience e;
  e.name = options.name;
  e.source_dir = options.source_dir;
  e.created_utc = UtcNow();
  e.kind = options.new_ground ? ExperienceKind::kNewGround : ExperienceKind::kRoute;
  e.first_image = static_cast<uint32_t>(out.num_images());
  e.num_images = static_cast<uint32_t>(added.frames.size());
  e.walk_frames = static_cast<uint32_t>(n);
  out.experiences.push_back(e);
  AppendImages(trained.map, added, &out, &s.landmarks_added);
  // New places have no look-alikes measured yet: empty lists keep the map's.
  if (out.has_lookalikes()) {
    for (size_t p = 0; p < s.new_places; ++p) {
      out.lookalike_offsets.push_back(out.lookalike_offsets.back());
    }
  }
  ExtendPlaceIndex(first_landmark, first_image, &pool, &out);
  // The off-map level is read from every image's holistic descriptor, the walk's too; each
  // walk has its own besides (confidence.h). The map's is measured again over every image
  // (samples x images: 1.1 s of an extension of a 1,000-location map); reading each frame
  // against its nearest walk's own level instead costs nothing per map but was measured less
  // well calibrated (docs/history.md, "Experiences").
  CalibrateMap(&out, &pool);
  for (Experience& x : out.experiences) {
    if (!x.calibration.valid) {
      x.calibration = CalibrateImages(out, static_cast<int>(x.first_image),
                                      static_cast<int>(x.num_images), &pool);
    }
  }
  SCENELOC_RETURN_IF_ERROR(out.Validate());
  out.Finalize();
  s.merge_seconds = watch.Seconds();
  return result;
}

}  // namespace sceneloc
