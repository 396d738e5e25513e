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

std::vector<float> ApproximateHolisticDistances(const FeatureSet& features, const Map& map,
                                                ThreadPool* pool) {
  const HolisticCodes& h = map.place_index.holistic;
  if (h.empty() || features.holistic.empty()) return {};
  const HolisticGrid& grid = map.holistic_grid;
  const int cols = grid.cols, cells = grid.cells(), bins = grid.bins;
  const int max_shift = std::clamp(map.options.extractor.holistic.max_shift, 0, cols - 1);
  const int shifts = 2 * max_shift + 1;
  const size_t n = static_cast<size_t>(map.num_images());
  constexpr size_t kCodes = kHolisticCodes;
  // Every query cell's squared distance to every code.
  std::vector<float> to_code(static_cast<size_t>(cells) * kCodes);
  float largest = 0;
  for (int q = 0; q < cells; ++q) {
    const float* cell = features.holistic.data() + static_cast<size_t>(q) * bins;
    for (size_t j = 0; j < kCodes; ++j) {
      const float* code = h.codebook.data() + j * static_cast<size_t>(bins);
      float d = 0;
      for (int b = 0; b < bins; ++b) d += (cell[b] - code[b]) * (cell[b] - code[b]);
      to_code[static_cast<size_t>(q) * kCodes + j] = d;
      largest = std::max(largest, d);
    }
  }
  // Sums in 16-bit fixed point, kLanes shifts at a time (one SIMD add a cell): a table
  // entry is at most 65535 / cells, so a location's sum over its cells cannot overflow.
  using Lanes = uint16_t __attribute__((vector_size(16)));
  constexpr int kLanes = 8;
  const float limit = std::floor(65535.0f / static_cast<float>(cells));
  const float scale = largest > 0 ? limit / largest : 0.0f;
  std::vector<float> out(n, std::numeric_limits<float>::max());
  std::vector<Lanes> table(static_cast<size_t>(cells) * kCodes);
  for (int first = 0; first < shifts; first += kLanes) {
    // Tour cell (r, c) with code j, lane i (shift s = first + i - max_shift): the distance of
    // query cell (r, c + s) to code j, or 0 where that cell is off the grid (HolisticDistance
    // compares query (r, c) with tour (r, c - s)).
    for (int p = 0; p < cells; ++p) {
      const int r = p / cols, c = p % cols;
      for (size_t j = 0; j < kCodes; ++j) {
        Lanes entry = {};
        for (int i = 0; i < kLanes && first + i < shifts; ++i) {
          const int qc = c + first + i - max_shift;
          if (qc < 0 || qc >= cols) continue;
          const float d = to_code[static_cast<size_t>(r * cols + qc) * kCodes + j];
          entry[i] = static_cast<uint16_t>(std::min(limit, std::floor(d * scale + 0.5f)));
        }
        table[static_cast<size_t>(p) * kCodes + j] = entry;
      }
    }
    const auto measure = [&](size_t begin, size_t end) {
      for (size_t l = begin; l < end; ++l) {
        const uint8_t* code = h.codes.data() + l * static_cast<size_t>(cells);
        Lanes sum = {};
        for (int p = 0; p < cells; ++p) sum += table[static_cast<size_t>(p) * kCodes + code[p]];
        for (int i = 0; i < kLanes && first + i < shifts; ++i) {
          const int overlap = grid.rows * (cols - std::abs(first + i - max_shift));
          out[l] = std::min(out[l], static_cast<float>(sum[i]) / (scale * overlap));
        }
      }
    };
    constexpr size_t kLocationsPerTask = 2048;
    if (scale == 0) {
      std::fill(out.begin(), out.end(), 0.0f);  // every query cell is at every code
    } else if (pool != nullptr) {
      pool->ParallelFor(n, kLocationsPerTask, measure);
    } else {
      measure(0, n);
    }
  }
  return out;
}

std::vector<int> HolisticShortlist(const std::vector<float>& approximate, int count) {
  std::vector<int> shortlist = Top(approximate, count, /*highest=*/false);
  std::sort(shortlist.begin(), shortlist.end());
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
  search.holistic = ApproximateHolisticDistances(features, map, pool);
  // The nearest by the approximation are measured exactly, and the nearest of those are the
  // candidates.
  const bool refine = !search.holistic.empty() && options.place_holistic_top > 0;
  const std::vector<int> shortlist =
      refine ? HolisticShortlist(search.holistic,
                                 std::max(kHolisticRefine, options.place_holistic_top))
             : std::vector<int>();
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
