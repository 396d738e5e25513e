#include "common/matching/place_search.h"

#include <algorithm>
#include <limits>
#include <numeric>

#include "common/matching/holistic_similarity.h"

namespace sceneloc {
namespace {

// Locations the approximate holistic distance shortlists for an exact one.
constexpr int kRefine = 128;

// The `count` locations of highest `value` (lowest index among equals), in no order.
std::vector<int> Top(const std::vector<float>& value, int count, bool highest) {
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
  return order;
}

}  // namespace

bool UsesPlaceSearch(const Map& map, const MatchOptions& options) {
  return options.use_place_index && map.has_place_index();
}

std::vector<float> WordScores(const FeatureSet& features, const Map& map) {
  std::vector<float> score(static_cast<size_t>(map.num_images()), 0.0f);
  if (features.size() == 0) return score;
  std::vector<uint32_t> words = AssignWords(map.place_index.vocabulary, features.local);
  std::sort(words.begin(), words.end());
  const InvertedFile& file = map.inverted_file;
  for (size_t i = 0; i < words.size();) {
    size_t j = i;
    while (j < words.size() && words[j] == words[i]) ++j;
    const uint32_t w = words[i];
    const float query_weight = static_cast<float>(j - i) * file.idf[w];
    for (uint32_t k = file.offsets[w]; k < file.offsets[w + 1]; ++k) {
      score[file.location[k]] += query_weight * file.weight[k];
    }
    i = j;
  }
  return score;
}

std::vector<float> ApproximateHolisticDistances(const FeatureSet& features, const Map& map) {
  const HolisticProjection& h = map.place_index.holistic;
  if (h.empty() || features.holistic.empty()) return {};
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
  // |q - t|^2 ~ |z - y|^2 + both residuals: the parts the axes leave out taken as orthogonal.
  std::vector<float> distance(n);
  for (size_t l = 0; l < n; ++l) {
    float best = std::numeric_limits<float>::max();
    for (int k = 0; k < shifts; ++k) {
      const float* y = h.projected.data() + (l * shifts + k) * dims;
      const float* q = z.data() + k * dims;
      float d2 = rest[static_cast<size_t>(k)] + h.residual[l * shifts + k];
      for (int a = 0; a < dims; ++a) d2 += (q[a] - y[a]) * (q[a] - y[a]);
      best = std::min(best, d2 / cells_per_shift[static_cast<size_t>(k)]);
    }
    distance[l] = best;
  }
  return distance;
}

PlaceSearch SearchPlaces(const FeatureSet& features, const Map& map, const MatchOptions& options) {
  PlaceSearch search;
  const int n = map.num_images();
  std::vector<bool> chosen(static_cast<size_t>(n), false);
  const auto choose = [&](const std::vector<int>& tops) {
    for (int l : tops) {
      for (int m = std::max(0, l - options.place_expand);
           m <= std::min(n - 1, l + options.place_expand); ++m) {
        chosen[static_cast<size_t>(m)] = true;
      }
    }
  };
  choose(Top(WordScores(features, map), options.place_word_top, /*highest=*/true));
  search.holistic = ApproximateHolisticDistances(features, map);
  if (!search.holistic.empty() && options.place_holistic_top > 0) {
    // The approximation ranks the nearest only roughly: its kRefine nearest are measured
    // exactly, and the nearest of those are the candidates.
    const std::vector<int> shortlist =
        Top(search.holistic, std::max(kRefine, options.place_holistic_top), /*highest=*/false);
    const std::vector<float> exact = HolisticDistancesTo(
        features, map, shortlist, map.options.extractor.holistic.max_shift, nullptr);
    std::vector<float> refined(search.holistic.size(), std::numeric_limits<float>::max());
    for (size_t i = 0; i < shortlist.size(); ++i) {
      search.holistic[shortlist[i]] = exact[i];
      refined[shortlist[i]] = exact[i];
    }
    choose(Top(refined, options.place_holistic_top, /*highest=*/false));
  }
  for (int l = 0; l < n; ++l) {
    if (chosen[static_cast<size_t>(l)]) search.locations.push_back(l);
  }
  return search;
}

}  // namespace sceneloc
