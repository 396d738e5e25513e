#include "common/training/candidate_chunks.h"

#include <algorithm>

#include "common/training/cooccurrence.h"
#include "common/training/landmark_builder.h"

namespace sceneloc {

size_t CandidateChunk::window_end() const {
  size_t end_image = end;
  for (const Track& t : tracks) end_image = std::max<size_t>(end_image, t.back().image + 1);
  return end_image;
}

std::vector<CandidateChunk> PlanChunks(std::vector<Track> tracks, const TourLinks& links,
                                       int min_track_length, int window, TrackedFeatures* tracked) {
  const size_t num_images = links.feature_counts.size();
  tracks.erase(
      std::remove_if(tracks.begin(), tracks.end(),
                     [&](const Track& t) { return static_cast<int>(t.size()) < min_track_length; }),
      tracks.end());
  tracked->tracked.resize(num_images);
  tracked->count.assign(num_images, 0);
  for (size_t i = 0; i < num_images; ++i) {
    tracked->tracked[i].assign(static_cast<size_t>(links.feature_counts[i]), false);
  }
  for (const Track& t : tracks) {
    for (const TrackObservation& o : t) {
      tracked->tracked[o.image][o.feature] = true;
      ++tracked->count[o.image];
    }
  }
  const size_t size = window > 0 ? static_cast<size_t>(window) : std::max<size_t>(num_images, 1);
  std::vector<CandidateChunk> chunks;
  for (size_t begin = 0; begin < num_images; begin += size) {
    CandidateChunk chunk;
    chunk.begin = begin;
    chunk.end = std::min(num_images, begin + size);
    chunks.push_back(std::move(chunk));
  }
  for (Track& t : tracks) chunks[t.front().image / size].tracks.push_back(std::move(t));
  return chunks;
}

size_t AddSingleViewCandidates(const TourWindow& window, const TrackedFeatures& tracked,
                               const TrainOptions& options, CandidateChunk* chunk) {
  size_t added = 0;
  for (size_t i = chunk->begin; i < chunk->end; ++i) {
    const std::vector<bool>& is_tracked = tracked.tracked[i];
    std::vector<uint32_t> free;
    for (uint32_t f = 0; f < is_tracked.size(); ++f) {
      if (!is_tracked[f]) free.push_back(f);
    }
    size_t take = free.size();  // min_track_length 1: every untracked feature
    if (options.min_track_length != 1) {
      const int wanted = std::max(0, options.min_landmarks_per_image - tracked.count[i]);
      take = std::min(static_cast<size_t>(wanted), free.size());
      const std::vector<Keypoint>& keypoints = window[i].keypoints;
      std::partial_sort(
          free.begin(), free.begin() + static_cast<std::ptrdiff_t>(take), free.end(),
          [&](uint32_t a, uint32_t b) { return keypoints[a].response > keypoints[b].response; });
    }
    for (size_t k = 0; k < take; ++k) chunk->tracks.push_back({{uint32_t(i), free[k]}});
    added += take;
  }
  return added;
}

StatusOr<Map> FuseCandidates(const std::vector<Track>& tracks, const TourWindow& window,
                             const std::vector<std::string>& image_names, int frame_width,
                             int frame_height, const TrainOptions& options) {
  Map candidates;
  candidates.options = options;
  candidates.image_names = image_names;
  candidates.image_width = frame_width;
  candidates.image_height = frame_height;
  FuseLandmarks(tracks, window, options, &candidates);
  BuildImageLists(&candidates);
  candidates.neighbour_offsets.assign(tracks.size() + 1, 0);
  SCENELOC_RETURN_IF_ERROR(candidates.Validate());
  candidates.Finalize();
  return candidates;
}

namespace {

template <typename T>
void Append(const std::vector<T>& from, std::vector<T>* to) {
  to->insert(to->end(), from.begin(), from.end());
}

template <typename Matrix>
void PlaceRows(const Matrix& from, Eigen::Index at, Matrix* to) {
  to->middleRows(at, from.rows()) = from;
}

}  // namespace

void ReserveLandmarks(size_t count, Map* map) {
  const auto rows = static_cast<Eigen::Index>(count);
  map->local_mean.resize(rows, kDescriptorSize);
  map->context_mean.resize(rows, kDescriptorSize);
  map->context_dmax.resize(rows, kNumHistograms);
  map->context_var.resize(rows, kNumHistograms);
  for (std::vector<float>* v : {&map->local_dmax, &map->local_var, &map->quality}) {
    v->clear();
    v->reserve(count);
  }
  map->observation_offsets.assign(1, 0);
  map->observation_offsets.reserve(count + 1);
}

void AppendLandmarks(const Map& part, Map* map) {
  const auto at = static_cast<Eigen::Index>(map->local_dmax.size());
  PlaceRows(part.local_mean, at, &map->local_mean);
  PlaceRows(part.context_mean, at, &map->context_mean);
  PlaceRows(part.context_dmax, at, &map->context_dmax);
  PlaceRows(part.context_var, at, &map->context_var);
  Append(part.local_dmax, &map->local_dmax);
  Append(part.local_var, &map->local_var);
  Append(part.quality, &map->quality);
  const uint32_t base = static_cast<uint32_t>(map->observation_image.size());
  for (size_t g = 1; g < part.observation_offsets.size(); ++g) {
    map->observation_offsets.push_back(base + part.observation_offsets[g]);
  }
  Append(part.observation_image, &map->observation_image);
  Append(part.observations, &map->observations);
}

}  // namespace sceneloc
