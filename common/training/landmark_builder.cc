#include "common/training/landmark_builder.h"

#include <algorithm>
#include <cmath>

namespace sceneloc {
namespace {

// Mean, largest distance and variance of distance ("the variance in Euclidean distance to
// the mean", read as the mean squared distance) of a set of vectors, for a slice of
// `width` columns starting at `offset`.
struct SpreadStats {
  float dmax = 0;
  float var = 0;
};

template <typename GetRow>
SpreadStats Spread(size_t count, GetRow row, const float* mean, int offset, int width) {
  SpreadStats s;
  double sum_d2 = 0;
  for (size_t k = 0; k < count; ++k) {
    const float* v = row(k);
    float d2 = 0;
    for (int c = offset; c < offset + width; ++c) {
      const float diff = v[c] - mean[c];
      d2 += diff * diff;
    }
    sum_d2 += d2;
    s.dmax = std::max(s.dmax, std::sqrt(d2));
  }
  s.var = static_cast<float>(sum_d2 / static_cast<double>(count));
  return s;
}

void FuseOne(const Track& track, const TourWindow& tour, const TrainOptions& options, int index,
             Map* map) {
  const auto local_row = [&](size_t k) {
    return tour[track[k].image].local.row(track[k].feature).data();
  };
  const auto context_row = [&](size_t k) {
    return tour[track[k].image].context.row(track[k].feature).data();
  };
  Eigen::Matrix<float, 1, kDescriptorSize> local_mean =
      Eigen::Matrix<float, 1, kDescriptorSize>::Zero();
  Eigen::Matrix<float, 1, kDescriptorSize> context_mean = local_mean;
  for (size_t k = 0; k < track.size(); ++k) {
    local_mean += tour[track[k].image].local.row(track[k].feature);
    context_mean += tour[track[k].image].context.row(track[k].feature);
  }
  local_mean /= static_cast<float>(track.size());
  context_mean /= static_cast<float>(track.size());
  // The map holds the means as bytes: the spreads are measured from the means it holds.
  for (int i = 0; i < kDescriptorSize; ++i) {
    map->local_mean(index, i) = UnitByte(local_mean[i]);
    map->context_mean(index, i) = UnitByte(context_mean[i]);
  }
  map->LocalMean(index, local_mean.data());
  map->ContextMean(index, context_mean.data());

  const SpreadStats local = Spread(track.size(), local_row, local_mean.data(), 0, kDescriptorSize);
  map->local_dmax[static_cast<size_t>(index)] = local.dmax;
  map->local_var[static_cast<size_t>(index)] =
      std::max(local.var, static_cast<float>(options.local_var_floor));
  for (int h = 0; h < kNumHistograms; ++h) {
    const SpreadStats s =
        Spread(track.size(), context_row, context_mean.data(), h * kHistogramBins, kHistogramBins);
    map->context_dmax(index, h) = ContextSpreadCode().Encode(s.dmax);
    // At least the code's lowest value (1e-6): a variance is never stored as 0.
    map->context_var(index, h) = std::max<uint8_t>(
        1,
        ContextSpreadCode().Encode(std::max(s.var, static_cast<float>(options.context_var_floor))));
  }
}

}  // namespace

void FuseLandmarks(const std::vector<Track>& tracks, const TourWindow& tour,
                   const TrainOptions& options, Map* map) {
  const auto n = static_cast<Eigen::Index>(tracks.size());
  map->local_mean.resize(n, kDescriptorSize);
  map->context_mean.resize(n, kDescriptorSize);
  map->context_dmax.resize(n, kNumHistograms);
  map->context_var.resize(n, kNumHistograms);
  map->local_dmax.assign(tracks.size(), 0);
  map->local_var.assign(tracks.size(), 0);
  map->quality.assign(tracks.size(), 0);
  map->observation_offsets.assign(1, 0);
  map->observation_image.clear();
  map->observations.clear();
  for (size_t t = 0; t < tracks.size(); ++t) {
    FuseOne(tracks[t], tour, options, static_cast<int>(t), map);
    for (const TrackObservation& o : tracks[t]) {
      const Keypoint& k = tour[o.image].keypoints[o.feature];
      map->AddObservation(o.image, k.x, k.y, k.size, k.angle);
    }
    map->observation_offsets.push_back(static_cast<uint32_t>(map->observation_image.size()));
  }
}

}  // namespace sceneloc
