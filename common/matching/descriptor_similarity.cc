#include "common/matching/descriptor_similarity.h"

#include <algorithm>
#include <array>
#include <cstdint>

#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif

#include "common/matching/similarity.h"

namespace sceneloc {
namespace {

// Landmarks per matrix-product block: big enough for an efficient GEMM, small enough that
// a block of scores for 1000 features (4 MB) stays in cache-friendly range.
constexpr size_t kLandmarkBlock = 512;

// The similarity of the query's context histogram h to the landmark's (its mean as bytes).
float HistogramSimilarity(const float* context, const uint8_t* mean, const Map& map, int landmark,
                          int h) {
  float d2 = 0;
  for (int b = 0; b < kHistogramBins; ++b) {
    const float diff = context[h * kHistogramBins + b] - UnitValue(mean[h * kHistogramBins + b]);
    d2 += diff * diff;
  }
  return SimilarityFromSquared(d2, map.ContextDmax(landmark, h), map.ContextVar(landmark, h));
}

float ContextSimilarity(const float* context, const Map& map, int landmark) {
  const uint8_t* mean = map.context_mean.row(landmark).data();
  float sum = 0;
  for (int h = 0; h < kNumHistograms; ++h) {
    sum += HistogramSimilarity(context, mean, map, landmark, h);
  }
  return sum / kNumHistograms;
}

// How far a sum of similarities computed in float may sit from the exact one; an early
// exit needs this much room to be sure.
constexpr float kSumSlack = 1e-3f;

// S_D of a pair whose local similarity is `local` (> 0), or 0 when it is surely below
// s_min: the context mean must reach s_min / local and each histogram adds at most 1, so
// the sum is given up as soon as the histograms left cannot lift it there (most pairs that
// pass the local test fail here, after a few of the 16). Otherwise exactly
// local * ContextSimilarity.
float PairSimilarity(float local, const float* context, const Map& map, int landmark, float s_min) {
  const float needed = s_min / local * kNumHistograms - kSumSlack;
  const uint8_t* mean = map.context_mean.row(landmark).data();
  float sum = 0;
  for (int h = 0; h < kNumHistograms; ++h) {
    if (sum + static_cast<float>(kNumHistograms - h) < needed) return 0;
    sum += HistogramSimilarity(context, mean, map, landmark, h);
  }
  return local * (sum / kNumHistograms);
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

// What the lower bound needs of the query's local descriptors (Map::local_basis).
struct QueryProjection {
  explicit QueryProjection(const FeatureSet& features, const Map& map)
      : sqnorm(features.local.rowwise().squaredNorm()),
        projected(features.local * map.local_basis),
        projected_sqnorm(projected.rowwise().squaredNorm()),
        residual_norm((features.local - projected * map.local_basis.transpose()).rowwise().norm()) {
  }
  Eigen::VectorXf sqnorm;            // |a|^2
  ProjectedMatrix projected;         // P^T a, one row per feature
  Eigen::VectorXf projected_sqnorm;  // |P^T a|^2
  Eigen::VectorXf residual_norm;     // |a - P P^T a|
};

// How far the bound, computed in float from sums of ~32 terms near 1, may sit above the
// exact one; pairs within it are decided by the exact distance. Squared distances between
// unit descriptors run 0-4, limits about 0.1-0.5.
constexpr float kBoundSlack = 1e-4f;

#if defined(__AVX2__) && defined(__FMA__)
// For each set of eight lanes (a bit mask), the set lanes' numbers packed to the front.
using PackTable = std::array<std::array<uint32_t, 8>, 256>;
const PackTable& LeftPackTable() {
  static const PackTable table = [] {
    PackTable t{};
    for (unsigned mask = 0; mask < 256; ++mask) {
      unsigned n = 0;
      for (uint32_t lane = 0; lane < 8; ++lane) {
        if ((mask >> lane) & 1u) t[mask][n++] = lane;
      }
    }
    return t;
  }();
  return table;
}
#endif

// Writes to `out` the features whose lower bound on the squared distance to one
// landmark (projected part |P^T a|^2 + p2 - 2 dots, plus the squared difference of the
// residual norms) is not above `threshold`; `dots` is the landmark's row of P^T mu . P^T a.
// About 96% of all pairs end here, so with AVX2 eight features are bounded and compared at
// once and their survivors' indices written without a branch (a left-packing table: which
// of eight survive is too random for the branch predictor). A NaN bound survives (as
// `!(b > t)`), leaving the exact distance to decide, as the scalar path does.
// Returns how many were written to `out`, which must have room for every feature plus 8.
uint32_t BoundSurvivors(const float* dots, const QueryProjection& query, float p2, float residual,
                        float threshold, uint32_t* out) {
  const auto count = static_cast<uint32_t>(query.projected_sqnorm.size());
  const float* projected = query.projected_sqnorm.data();
  const float* residuals = query.residual_norm.data();
  const float limit = threshold - p2;
  uint32_t kept = 0;
  uint32_t i = 0;
#if defined(__AVX2__) && defined(__FMA__)
  const PackTable& pack = LeftPackTable();
  const __m256 v_limit = _mm256_set1_ps(limit);
  const __m256 v_residual = _mm256_set1_ps(residual);
  const __m256 v_two = _mm256_set1_ps(2.0f);
  for (; i + 8 <= count; i += 8) {
    const __m256 dr = _mm256_sub_ps(_mm256_loadu_ps(residuals + i), v_residual);
    __m256 bound =
        _mm256_fnmadd_ps(v_two, _mm256_loadu_ps(dots + i), _mm256_loadu_ps(projected + i));
    bound = _mm256_fmadd_ps(dr, dr, bound);
    const auto mask =
        static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(bound, v_limit, _CMP_NGT_UQ)));
    const __m256i lanes = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(pack[mask].data()));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + kept),
                        _mm256_add_epi32(lanes, _mm256_set1_epi32(static_cast<int>(i))));
    kept += static_cast<uint32_t>(__builtin_popcount(mask));
  }
#endif
  for (; i < count; ++i) {
    const float dr = residuals[i] - residual;
    const float bound = projected[i] - 2.0f * dots[i] + dr * dr;
    out[kept] = i;
    kept += !(bound > limit) ? 1 : 0;
  }
  return kept;
}

// What S_D's lower bound reads of the scope's landmarks at positions [begin, end): a view of
// the map's projections (whole scope) or a copy of them (a scope of a map that keeps them),
// or projections made here from the means (a map that does not keep them).
class BlockProjection {
 public:
  BlockProjection(const Map& map, const LandmarkScope& scope, size_t begin, size_t end)
      : rows_(static_cast<Eigen::Index>(end - begin)) {
    if (map.keeps_projections() && scope.whole()) {
      view_ = &map.local_projected;
      at_ = static_cast<Eigen::Index>(begin);
      sqnorm_ = map.local_projected_sqnorm.data() + begin;
      residual_ = map.local_residual_norm.data() + begin;
      return;
    }
    own_.resize(rows_, kBoundDims);
    own_sqnorm_.resize(static_cast<size_t>(rows_));
    own_residual_.resize(static_cast<size_t>(rows_));
    if (map.keeps_projections()) {
      for (Eigen::Index r = 0; r < rows_; ++r) {
        const uint32_t g = scope.landmark(begin + static_cast<size_t>(r));
        own_.row(r) = map.local_projected.row(g);
        own_sqnorm_[static_cast<size_t>(r)] = map.local_projected_sqnorm[g];
        own_residual_[static_cast<size_t>(r)] = map.local_residual_norm[g];
      }
    } else {
      DescriptorMatrix means(rows_, kDescriptorSize);
      for (Eigen::Index r = 0; r < rows_; ++r) {
        map.LocalMean(static_cast<int>(scope.landmark(begin + static_cast<size_t>(r))),
                      means.row(r).data());
      }
      ProjectBlock(means, map.local_basis, &own_, 0, &own_sqnorm_, &own_residual_);
    }
    view_ = &own_;
    sqnorm_ = own_sqnorm_.data();
    residual_ = own_residual_.data();
  }
  auto projected() const { return view_->middleRows(at_, rows_); }
  float sqnorm(Eigen::Index r) const { return sqnorm_[r]; }
  float residual_norm(Eigen::Index r) const { return residual_[r]; }

 private:
  Eigen::Index rows_;
  const ProjectedMatrix* view_ = nullptr;
  Eigen::Index at_ = 0;
  const float* sqnorm_ = nullptr;
  const float* residual_ = nullptr;
  ProjectedMatrix own_;
  std::vector<float> own_sqnorm_, own_residual_;
};

// Scores features against the scope's landmarks at positions [begin, end) and appends the
// survivors to `out` (by position). First a lower bound on every pair's squared distance
// from a matrix product at a quarter of the descriptor's width (Map::local_basis); only the
// pairs it cannot rule out (a few percent) get their exact distance, as one 128-wide dot
// product each.
void MatchBlock(const FeatureSet& features, const QueryProjection& query, const Map& map,
                const LandmarkScope& scope, float s_min, size_t cap, size_t begin, size_t end,
                std::vector<DescriptorMatch>* out) {
  const auto n = static_cast<Eigen::Index>(end - begin);
  // dots(j, i) = P^T mu_j . P^T a_i; landmark-major so each landmark's column of features
  // is contiguous and the results come out ordered by landmark.
  // The block's projections: the map's own in a map searched whole, else made here from
  // its landmarks' means (a big map does not keep them).
  const BlockProjection block(map, scope, begin, end);
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> dots;
  dots.noalias() = block.projected() * query.projected.transpose();
  std::vector<uint32_t> survivors(static_cast<size_t>(dots.cols()) + 8);
  std::vector<float> distances(static_cast<size_t>(dots.cols()));
  for (Eigen::Index r = 0; r < n; ++r) {
    const uint32_t position = static_cast<uint32_t>(begin) + static_cast<uint32_t>(r);
    const int landmark = static_cast<int>(scope.landmark(position));
    const float dmax = map.local_dmax[landmark];
    const float var = map.local_var[landmark];
    const float limit = SquaredDistanceLimit(dmax, var, s_min);
    const float mu2 = map.local_mean_sqnorm[landmark];
    const size_t first = out->size();
    const uint32_t kept =
        BoundSurvivors(dots.row(r).data(), query, block.sqnorm(r), block.residual_norm(r),
                       limit + kBoundSlack, survivors.data());
    if (kept == 0) continue;
    Eigen::Matrix<float, 1, kDescriptorSize> mean;
    map.LocalMean(landmark, mean.data());
    // The exact distances, then the pairs within the limit packed to the front in place
    // (no branch on each: a sixth of them pass, at random), then the context term.
    uint32_t close = 0;
    for (uint32_t k = 0; k < kept; ++k) {
      const uint32_t i = survivors[k];
      const float d2 =
          std::max(0.0f, query.sqnorm[i] + mu2 - 2.0f * mean.dot(features.local.row(i)));
      survivors[close] = i;
      distances[close] = d2;
      close += d2 <= limit ? 1 : 0;
    }
    for (uint32_t k = 0; k < close; ++k) {
      const uint32_t i = survivors[k];
      const float local = SimilarityFromSquared(distances[k], dmax, var);
      const float s = PairSimilarity(local, features.context.row(i).data(), map, landmark, s_min);
      if (s >= s_min) out->push_back({i, position, s});
    }
    CapLandmarkMatches(first, cap, out);
  }
}

}  // namespace

std::vector<DescriptorMatch> ComputeDescriptorMatches(const FeatureSet& features, const Map& map,
                                                      float s_min, ThreadPool* pool,
                                                      int max_per_landmark) {
  return ComputeDescriptorMatches(features, map, LandmarkScope::Whole(map), s_min, pool,
                                  max_per_landmark);
}

std::vector<DescriptorMatch> ComputeDescriptorMatches(const FeatureSet& features, const Map& map,
                                                      const LandmarkScope& scope, float s_min,
                                                      ThreadPool* pool, int max_per_landmark) {
  const size_t cap = static_cast<size_t>(std::max(0, max_per_landmark));
  const size_t num_landmarks = scope.size();
  if (features.size() == 0 || num_landmarks == 0) return {};
  const QueryProjection query(features, map);
  const size_t num_blocks = (num_landmarks + kLandmarkBlock - 1) / kLandmarkBlock;
  std::vector<std::vector<DescriptorMatch>> per_block(num_blocks);
  auto run = [&](size_t block_begin, size_t block_end) {
    for (size_t b = block_begin; b < block_end; ++b) {
      const size_t begin = b * kLandmarkBlock;
      MatchBlock(features, query, map, scope, s_min, cap, begin,
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
  Eigen::Matrix<float, 1, kDescriptorSize> mean;
  map.LocalMean(landmark, mean.data());
  const float d2 = (features.local.row(feature) - mean).squaredNorm();
  const float local = SimilarityFromSquared(d2, map.local_dmax[landmark], map.local_var[landmark]);
  return local * ContextSimilarity(features.context.row(feature).data(), map, landmark);
}

}  // namespace sceneloc
