#include "common/training/quality.h"

#include "common/matching/descriptor_similarity.h"

namespace sceneloc {
namespace {

// owner[image - first][feature] = the landmark the feature was fused into, or -1.
std::vector<std::vector<int>> FeatureOwners(const std::vector<Track>& tracks,
                                            const TourWindow& tour) {
  std::vector<std::vector<int>> owner(tour.size());
  for (size_t i = 0; i < tour.size(); ++i) {
    owner[i].assign(static_cast<size_t>(tour[tour.first() + i].size()), -1);
  }
  for (size_t t = 0; t < tracks.size(); ++t) {
    for (const TrackObservation& o : tracks[t]) {
      owner[o.image - tour.first()][o.feature] = static_cast<int>(t);
    }
  }
  return owner;
}

struct Contribution {
  uint32_t landmark;
  bool true_positive;
  double mass;  // p(g|f) * S_D(f, g)
};

// One image's contributions to the true- and false-positive masses.
std::vector<Contribution> ImageContributions(const std::vector<DescriptorMatch>& matches,
                                             const std::vector<int>& owner, int num_features) {
  // Denominator of p(g|f): the total similarity mass of each feature.
  std::vector<double> mass(static_cast<size_t>(num_features), 0.0);
  for (const DescriptorMatch& m : matches) mass[m.feature] += m.similarity;
  std::vector<Contribution> out;
  out.reserve(matches.size());
  for (const DescriptorMatch& m : matches) {
    const double p = m.similarity / mass[m.feature];
    out.push_back({m.landmark, owner[m.feature] == static_cast<int>(m.landmark), p * m.similarity});
  }
  return out;
}

}  // namespace

std::vector<float> ComputeQuality(const Map& candidates, const std::vector<Track>& tracks,
                                  const TourWindow& tour, double s_min, double fp_prior,
                                  ThreadPool* pool,
                                  const std::function<void(size_t, size_t)>& progress) {
  const size_t num_landmarks = static_cast<size_t>(candidates.num_landmarks());
  const auto owner = FeatureOwners(tracks, tour);
  std::vector<double> tp(num_landmarks, 0.0), fp(num_landmarks, 0.0);
  // Images are scored in parallel (each image's product runs inline in its worker: one
  // image is too small to split well, a tour has hundreds) and summed in image order, so
  // Q does not depend on the thread count. Progress is reported between batches.
  const size_t batch = pool != nullptr ? static_cast<size_t>(pool->num_threads()) * 4 : 8;
  std::vector<std::vector<Contribution>> contributions(batch);
  for (size_t begin = 0; begin < tour.size(); begin += batch) {
    const size_t end = std::min(tour.size(), begin + batch);
    auto run = [&](size_t b, size_t e) {
      for (size_t i = begin + b; i < begin + e; ++i) {
        const FeatureSet& image = tour[tour.first() + i];
        const auto matches =
            ComputeDescriptorMatches(image, candidates, static_cast<float>(s_min), nullptr);
        contributions[i - begin] = ImageContributions(matches, owner[i], image.size());
      }
    };
    if (pool != nullptr) {
      pool->ParallelFor(end - begin, 1, run);
    } else {
      run(0, end - begin);
    }
    for (size_t i = begin; i < end; ++i) {
      for (const Contribution& c : contributions[i - begin]) {
        (c.true_positive ? tp : fp)[c.landmark] += c.mass;
      }
    }
    if (progress) progress(end, tour.size());
  }
  std::vector<float> quality(num_landmarks);
  for (size_t j = 0; j < num_landmarks; ++j) {
    quality[j] = static_cast<float>(tp[j] / (fp_prior + fp[j]));
  }
  return quality;
}

}  // namespace sceneloc
