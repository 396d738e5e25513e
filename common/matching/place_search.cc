#include "common/matching/place_search.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>

#include "common/matching/holistic_similarity.h"

namespace sceneloc {
namespace {

// The `count` locations of highest `value` (lowest index among equals), best first if
// `ordered`, else in no order.
std::vector<int> Top(const std::vector<float>& value, int count, bool highest,
                     bool ordered = false) {
  std::vector<int> order(value.size());
  std::iota(order.begin(), order.end(), 0);
  const size_t k = std::min(order.size(), static_cast<size_t>(std::max(0, count)));
  const auto better = [&](int a, int b) {
    if (value[a] != value[b]) return highest ? value[a] > value[b] : value[a] < value[b];
    return a < b;
  };
  std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k), order.end(),
                   better);
  order.resize(k);
  if (ordered) std::sort(order.begin(), order.end(), better);
  return order;
}

}  // namespace

bool UsesPlaceSearch(const Map& map, const MatchOptions& options) {
  return options.use_place_index && map.has_place_index();
}

std::vector<float> WordScores(const FeatureSet& features, const Map& map, int hamming_max,
                              ThreadPool* pool) {
  std::vector<float> score(static_cast<size_t>(map.num_images()), 0.0f);
  if (features.size() == 0) return score;
  // The features' words (and signatures) in blocks of kRowsPerBlock rows, the blocks spread
  // over the pool; a row's word does not depend on the other rows, and the blocks are the
  // same whatever the pool, so the words are too.
  constexpr size_t kRowsPerBlock = 256;
  const size_t rows = static_cast<size_t>(features.local.rows());
  const InvertedFile& file = map.inverted_file;
  const bool hamming = hamming_max > 0;
  std::vector<uint32_t> words(rows);
  std::vector<uint64_t> signatures(hamming ? rows : 0);
  const auto assign = [&](size_t first_block, size_t end_block) {
    for (size_t b = first_block; b < end_block; ++b) {
      const size_t begin = b * kRowsPerBlock, count = std::min(kRowsPerBlock, rows - begin);
      const DescriptorMatrix block = features.local.middleRows(static_cast<Eigen::Index>(begin),
                                                               static_cast<Eigen::Index>(count));
      const std::vector<uint32_t> part = AssignWords(map.place_index.vocabulary, block);
      std::copy(part.begin(), part.end(), words.begin() + static_cast<std::ptrdiff_t>(begin));
      if (hamming) {
        const std::vector<uint64_t> bits = Signatures(file, block, part);
        std::copy(bits.begin(), bits.end(),
                  signatures.begin() + static_cast<std::ptrdiff_t>(begin));
      }
    }
  };
  const size_t blocks = (rows + kRowsPerBlock - 1) / kRowsPerBlock;
  if (pool != nullptr) {
    pool->ParallelFor(blocks, 1, assign);
  } else {
    assign(0, blocks);
  }
  if (hamming) {
    // Each feature against the occurrences of its word: idf^2, weighted by how near the
    // signatures are (exp(-h^2 / sigma^2), sigma = 16 of 64 bits, as Jegou et al.), within
    // hamming_max bits.
    std::array<float, kSignatureBits + 1> near{};
    for (int h = 0; h <= std::min(hamming_max, kSignatureBits); ++h) {
      near[static_cast<size_t>(h)] = std::exp(-static_cast<float>(h * h) / (16.0f * 16.0f));
    }
    for (size_t i = 0; i < rows; ++i) {
      const uint32_t w = words[i];
      const float idf2 = file.idf[w] * file.idf[w];
      const uint64_t bits = signatures[i];
      for (uint32_t k = file.offsets[w]; k < file.offsets[w + 1]; ++k) {
        const int h = __builtin_popcountll(bits ^ file.signature[k]);
        score[file.location[k]] += idf2 * near[static_cast<size_t>(h)];
      }
    }
  } else {
    // tf-idf: the query's count of a word times its idf, against each occurrence's idf.
    std::sort(words.begin(), words.end());
    for (size_t i = 0; i < words.size();) {
      size_t j = i;
      while (j < words.size() && words[j] == words[i]) ++j;
      const uint32_t w = words[i];
      const float weight = static_cast<float>(j - i) * file.idf[w] * file.idf[w];
      for (uint32_t k = file.offsets[w]; k < file.offsets[w + 1]; ++k) {
        score[file.location[k]] += weight;
      }
      i = j;
    }
  }
  // Each location's tf-idf vector at unit norm.
  for (size_t l = 0; l < score.size(); ++l) score[l] *= file.location_scale[l];
  return score;
}

ApproximateHolistic ApproximateHolisticDistances(const FeatureSet& features, const Map& map,
                                                 ThreadPool* pool) {
  const HolisticProjection& h = map.place_index.holistic;
  ApproximateHolistic out;
  if (h.empty() || features.holistic.empty()) return out;
  const HolisticGrid& grid = map.holistic_grid;
  const int shifts = h.num_shifts(), dims = h.dims;
  const size_t n = static_cast<size_t>(map.num_images());
  // Per shift: the query's projection z, what the axes leave of it, and the cells compared.
  std::vector<float> z(static_cast<size_t>(shifts * dims)), rest(static_cast<size_t>(shifts));
  std::vector<float> cells_per_shift(static_cast<size_t>(shifts));
  std::vector<float> cells;
  for (int k = 0; k < shifts; ++k) {
    const int shift = k - h.max_shift;
    ShiftedCells(features.holistic.data(), grid, shift, /*query=*/true, &cells);
    const size_t offset = h.MeanOffset(k, grid);
    const size_t span = cells.size();
    float norm = 0;
    for (size_t i = 0; i < span; ++i) {
      cells[i] -= h.mean[offset + i];
      norm += cells[i] * cells[i];
    }
    float projected = 0;
    for (int a = 0; a < dims; ++a) {
      const float* axis = h.axes.data() + offset * dims + static_cast<size_t>(a) * span;
      float dot = 0;
      for (size_t i = 0; i < span; ++i) dot += axis[i] * cells[i];
      z[static_cast<size_t>(k * dims + a)] = dot;
      projected += dot * dot;
    }
    rest[static_cast<size_t>(k)] = std::max(0.0f, norm - projected);
    cells_per_shift[static_cast<size_t>(k)] =
        static_cast<float>(grid.rows * (grid.cols - std::abs(shift)));
  }
  // Within the axes, |z - y|^2 per compared cell: the nearness. As a distance,
  // |q - t|^2 ~ |z - y|^2 + both residuals (the parts the axes leave out taken as
  // orthogonal). Each the least over the shifts.
  out.nearness.resize(n);
  out.distance.resize(n);
  const auto measure = [&](size_t begin, size_t end) {
    for (size_t l = begin; l < end; ++l) {
      float nearest = std::numeric_limits<float>::max(), best = nearest;
      for (int k = 0; k < shifts; ++k) {
        const float* y = h.projected.data() + (l * shifts + k) * dims;
        const float* q = z.data() + k * dims;
        float d2 = 0;
        for (int a = 0; a < dims; ++a) d2 += (q[a] - y[a]) * (q[a] - y[a]);
        const float cells = cells_per_shift[static_cast<size_t>(k)];
        nearest = std::min(nearest, d2 / cells);
        best = std::min(best,
                        (d2 + rest[static_cast<size_t>(k)] + h.residual[l * shifts + k]) / cells);
      }
      out.nearness[l] = nearest;
      out.distance[l] = best;
    }
  };
  constexpr size_t kLocationsPerTask = 2048;
  if (pool != nullptr) {
    pool->ParallelFor(n, kLocationsPerTask, measure);
  } else {
    measure(0, n);
  }
  return out;
}

std::vector<int> HolisticShortlist(const ApproximateHolistic& approximate, int count) {
  std::vector<int> shortlist = Top(approximate.nearness, count, /*highest=*/false);
  const std::vector<int> by_distance = Top(approximate.distance, count, /*highest=*/false);
  shortlist.insert(shortlist.end(), by_distance.begin(), by_distance.end());
  std::sort(shortlist.begin(), shortlist.end());
  shortlist.erase(std::unique(shortlist.begin(), shortlist.end()), shortlist.end());
  return shortlist;
}

PlaceSearch SearchPlaces(const FeatureSet& features, const Map& map, const MatchOptions& options,
                         ThreadPool* pool) {
  PlaceSearch search;
  const int n = map.num_images();
  const int expand = options.place_expand;
  std::vector<bool> chosen(static_cast<size_t>(n), false);
  int chosen_count = 0;
  const auto choose = [&](int l) {
    for (int m = std::max(0, l - expand); m <= std::min(n - 1, l + expand); ++m) {
      chosen_count += !chosen[static_cast<size_t>(m)];
      chosen[static_cast<size_t>(m)] = true;
    }
  };
  // The `count` best of `value` as picks; with place_distinct, a location already chosen is
  // passed over. Each pick chooses at most 2 * expand others, so the best
  // count * (2 * expand + 1) beyond those already chosen hold every pick. A location whose
  // value is the worst a float holds (not measured) is never picked.
  const auto pick = [&](const std::vector<float>& value, int count, bool highest) {
    const float unmeasured =
        highest ? std::numeric_limits<float>::lowest() : std::numeric_limits<float>::max();
    if (!options.place_distinct) {
      for (int l : Top(value, count, highest)) {
        if (value[l] != unmeasured) choose(l);
      }
      return;
    }
    const std::vector<int> best =
        Top(value, count * (2 * expand + 1) + chosen_count, highest, /*ordered=*/true);
    int picked = 0;
    for (int l : best) {
      if (picked == count || value[l] == unmeasured) break;
      if (chosen[static_cast<size_t>(l)]) continue;
      choose(l);
      ++picked;
    }
  };
  pick(WordScores(features, map, options.place_hamming_max, pool), options.place_word_top,
       /*highest=*/true);
  ApproximateHolistic approximate = ApproximateHolisticDistances(features, map, pool);
  // The approximation ranks the nearest only roughly: its shortlist is measured exactly, and
  // the nearest of those are the candidates.
  const bool refine = !approximate.distance.empty() && options.place_holistic_top > 0;
  const std::vector<int> shortlist =
      refine ? HolisticShortlist(approximate, std::max(kHolisticRefine, options.place_holistic_top))
             : std::vector<int>();
  search.holistic = std::move(approximate.distance);
  if (refine) {
    const std::vector<float> exact = HolisticDistancesTo(
        features, map, shortlist, map.options.extractor.holistic.max_shift, pool);
    std::vector<float> refined(search.holistic.size(), std::numeric_limits<float>::max());
    for (size_t i = 0; i < shortlist.size(); ++i) {
      search.holistic[shortlist[i]] = exact[i];
      refined[shortlist[i]] = exact[i];
    }
    pick(refined, options.place_holistic_top, /*highest=*/false);
  }
  for (int l = 0; l < n; ++l) {
    if (chosen[static_cast<size_t>(l)]) search.locations.push_back(l);
  }
  return search;
}

}  // namespace sceneloc
