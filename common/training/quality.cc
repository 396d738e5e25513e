#include "common/training/quality.h"

#include <mutex>

#include "common/matching/descriptor_similarity.h"

namespace sceneloc {
namespace {

// owner[image][feature] = the landmark the feature was fused into, or -1.
std::vector<std::vector<int>> FeatureOwners(const std::vector<Track>& tracks,
                                            const std::vector<FeatureSet>& tour) {
  std::vector<std::vector<int>> owner(tour.size());
  for (size_t i = 0; i < tour.size(); ++i) owner[i].assign(static_cast<size_t>(tour[i].size()), -1);
  for (size_t t = 0; t < tracks.size(); ++t) {
    for (const TrackObservation& o : tracks[t]) owner[o.image][o.feature] = static_cast<int>(t);
  }
  return owner;
}

// Adds one image's contribution to the true- and false-positive masses.
void AccumulateImage(const std::vector<DescriptorMatch>& matches, const std::vector<int>& owner,
                     int num_features, std::vector<double>* tp, std::vector<double>* fp) {
  // Denominator of p(g|f): the total similarity mass of each feature.
  std::vector<double> mass(static_cast<size_t>(num_features), 0.0);
  for (const DescriptorMatch& m : matches) mass[m.feature] += m.similarity;
  for (const DescriptorMatch& m : matches) {
    const double p = m.similarity / mass[m.feature];
    const double contribution = p * m.similarity;
    if (owner[m.feature] == static_cast<int>(m.landmark)) {
      (*tp)[m.landmark] += contribution;
    } else {
      (*fp)[m.landmark] += contribution;
    }
  }
}

}  // namespace

std::vector<float> ComputeQuality(const Map& candidates, const std::vector<Track>& tracks,
                                  const std::vector<FeatureSet>& tour, double s_min,
                                  double fp_prior, ThreadPool* pool,
                                  const std::function<void(size_t, size_t)>& progress) {
  const size_t num_landmarks = static_cast<size_t>(candidates.num_landmarks());
  const auto owner = FeatureOwners(tracks, tour);
  std::vector<double> tp(num_landmarks, 0.0), fp(num_landmarks, 0.0);
  std::mutex mutex;  // guards tp, fp and the progress count
  size_t done = 0;
  // Images in parallel (each image's scoring runs inline in its worker): one image's
  // product is too small to split well, a tour has hundreds of images.
  auto run = [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const auto matches =
          ComputeDescriptorMatches(tour[i], candidates, static_cast<float>(s_min), nullptr);
      std::lock_guard<std::mutex> lock(mutex);
      AccumulateImage(matches, owner[i], tour[i].size(), &tp, &fp);
      ++done;
    }
  };
  // Progress is reported from this thread between batches of images.
  const size_t batch = pool != nullptr ? static_cast<size_t>(pool->num_threads()) * 4 : 8;
  for (size_t begin = 0; begin < tour.size(); begin += batch) {
    const size_t end = std::min(tour.size(), begin + batch);
    if (pool != nullptr) {
      pool->ParallelFor(end - begin, 1, [&](size_t b, size_t e) { run(begin + b, begin + e); });
    } else {
      run(begin, end);
    }
    if (progress) progress(done, tour.size());
  }
  std::vector<float> quality(num_landmarks);
  for (size_t j = 0; j < num_landmarks; ++j) {
    quality[j] = static_cast<float>(tp[j] / (fp_prior + fp[j]));
  }
  return quality;
}

}  // namespace sceneloc
