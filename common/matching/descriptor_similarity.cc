#include "common/matching/descriptor_similarity.h"

#include <algorithm>
#include <mutex>

#include "common/matching/similarity.h"

namespace sceneloc {
namespace {

// Landmarks per matrix-product block: big enough for an efficient GEMM, small enough that
// a block of scores for 1000 features (4 MB) stays in cache-friendly range.
constexpr size_t kLandmarkBlock = 512;

float ContextSimilarity(const float* context, const Map& map, int landmark) {
  const float* mean = map.context_mean.row(landmark).data();
  float sum = 0;
  for (int h = 0; h < kNumHistograms; ++h) {
    float d2 = 0;
    for (int b = 0; b < kHistogramBins; ++b) {
      const float diff = context[h * kHistogramBins + b] - mean[h * kHistogramBins + b];
      d2 += diff * diff;
    }
    sum += SimilarityFromSquared(d2, map.context_dmax(landmark, h), map.context_var(landmark, h));
  }
  return sum / kNumHistograms;
}

// Keeps the `cap` best of one landmark's matches (appended from `first` on), in feature order.
void CapLandmarkMatches(size_t first, size_t cap, std::vector<DescriptorMatch>* out) {
  const auto begin = out->begin() + static_cast<std::ptrdiff_t>(first);
  if (cap == 0 || static_cast<size_t>(out->end() - begin) <= cap) return;
  const auto better = [](const DescriptorMatch& a, const DescriptorMatch& b) {
    return a.similarity > b.similarity || (a.similarity == b.similarity && a.feature < b.feature);
  };
  std::nth_element(begin, begin + static_cast<std::ptrdiff_t>(cap) - 1, out->end(), better);
  out->erase(begin + static_cast<std::ptrdiff_t>(cap), out->end());
  std::sort(begin, out->end(), [](const DescriptorMatch& a, const DescriptorMatch& b) {
    return a.feature < b.feature;
  });
}

// Scores features against landmarks [begin, end) and appends the survivors to `out`.
void MatchBlock(const FeatureSet& features, const Eigen::VectorXf& feature_sqnorm, const Map& map,
                float s_min, size_t cap, size_t begin, size_t end,
                std::vector<DescriptorMatch>* out) {
  const auto n = static_cast<Eigen::Index>(end - begin);
  // dots(j, i) = mu_j . a_i; landmark-major so each landmark's column of features is
  // contiguous and the results come out ordered by landmark.
  const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> dots =
      map.local_mean.middleRows(static_cast<Eigen::Index>(begin), n) * features.local.transpose();
  for (Eigen::Index r = 0; r < n; ++r) {
    const int landmark = static_cast<int>(begin) + static_cast<int>(r);
    const float dmax = map.local_dmax[landmark];
    const float var = map.local_var[landmark];
    const float limit = SquaredDistanceLimit(dmax, var, s_min);
    const float mu2 = map.local_mean_sqnorm[landmark];
    const size_t first = out->size();
    for (Eigen::Index i = 0; i < dots.cols(); ++i) {
      const float d2 = std::max(0.0f, feature_sqnorm[i] + mu2 - 2.0f * dots(r, i));
      if (d2 > limit) continue;
      const float local = SimilarityFromSquared(d2, dmax, var);
      const float s = local * ContextSimilarity(features.context.row(i).data(), map, landmark);
      if (s >= s_min) {
        out->push_back({static_cast<uint32_t>(i), static_cast<uint32_t>(landmark), s});
      }
    }
    CapLandmarkMatches(first, cap, out);
  }
}

}  // namespace

std::vector<DescriptorMatch> ComputeDescriptorMatches(const FeatureSet& features, const Map& map,
                                                      float s_min, ThreadPool* pool,
                                                      int max_per_landmark) {
  const size_t cap = static_cast<size_t>(std::max(0, max_per_landmark));
  const size_t num_landmarks = static_cast<size_t>(map.num_landmarks());
  if (features.size() == 0 || num_landmarks == 0) return {};
  const Eigen::VectorXf feature_sqnorm = features.local.rowwise().squaredNorm();
  const size_t num_blocks = (num_landmarks + kLandmarkBlock - 1) / kLandmarkBlock;
  std::vector<std::vector<DescriptorMatch>> per_block(num_blocks);
  auto run = [&](size_t block_begin, size_t block_end) {
    for (size_t b = block_begin; b < block_end; ++b) {
      const size_t begin = b * kLandmarkBlock;
      MatchBlock(features, feature_sqnorm, map, s_min, cap, begin,
                 std::min(num_landmarks, begin + kLandmarkBlock), &per_block[b]);
    }
  };
  if (pool != nullptr) {
    pool->ParallelFor(num_blocks, 1, run);
  } else {
    run(0, num_blocks);
  }
  size_t total = 0;
  for (const auto& block : per_block) total += block.size();
  std::vector<DescriptorMatch> matches;
  matches.reserve(total);
  for (const auto& block : per_block) matches.insert(matches.end(), block.begin(), block.end());
  return matches;
}

float DescriptorSimilarity(const FeatureSet& features, int feature, const Map& map, int landmark) {
  const float d2 = (features.local.row(feature) - map.local_mean.row(landmark)).squaredNorm();
  const float local = SimilarityFromSquared(d2, map.local_dmax[landmark], map.local_var[landmark]);
  return local * ContextSimilarity(features.context.row(feature).data(), map, landmark);
}

}  // namespace sceneloc
