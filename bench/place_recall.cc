// The coarse stage's recall: for each query folder, how often one of the first K distinct
// picks (place_search.h, place_expand 3) lies within the tolerance of the query's true place
// (file-name truth): by words, at each Hamming limit asked, and by holistic distance, exact
// over the whole map and as the coarse stage measures it (approximate, its shortlist
// exact). What the fine stage can answer is bounded by it; `sceneloc-eval` measures
// the answers themselves.
//
//   place_recall --map BIG.scnl --queries DIR... [--hamming 0 24 32] [--cache DIR]
//
// Not a Google Benchmark: it prints one table per folder and the mean over the folders.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

#include "common/map/map_io.h"
#include "common/matching/holistic_similarity.h"
#include "common/matching/place_search.h"
#include "common/util/image_folder.h"
#include "tools/eval/evaluation.h"
#include "tools/eval/feature_cache.h"

namespace sl = sceneloc;

namespace {

constexpr int kExpand = 3;     // as MatchOptions::place_expand
constexpr int kTolerance = 2;  // frames

// The rank (1-based) of the first distinct pick of `value` (best first; a location within
// kExpand of an earlier pick is passed over) within kTolerance of `truth`; 0 if none of the
// first `max_picks` is.
int PickRank(const std::vector<float>& value, int truth, int max_picks) {
  const int n = static_cast<int>(value.size());
  std::vector<int> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  const int k = std::min(n, max_picks * (2 * kExpand + 1) + 1);
  std::partial_sort(order.begin(), order.begin() + k, order.end(), [&](int a, int b) {
    return value[a] > value[b] || (value[a] == value[b] && a < b);
  });
  std::vector<bool> chosen(static_cast<size_t>(n), false);
  int picked = 0;
  for (int i = 0; i < k && picked < max_picks; ++i) {
    const int l = order[static_cast<size_t>(i)];
    if (chosen[static_cast<size_t>(l)]) continue;
    ++picked;
    if (std::abs(l - truth) <= kTolerance) return picked;
    for (int m = std::max(0, l - kExpand); m <= std::min(n - 1, l + kExpand); ++m) {
      chosen[static_cast<size_t>(m)] = true;
    }
  }
  return 0;
}

// Negated holistic distances (nearer is higher, as PickRank reads): exact to every location
// if `exact`, else as SearchPlaces measures them (its HolisticShortlist exact, the rest never
// picked).
std::vector<float> HolisticValues(const sl::FeatureSet& query, const sl::Map& map, bool exact) {
  const int max_shift = map.options.extractor.holistic.max_shift;
  std::vector<float> value;
  if (exact) {
    value = sl::HolisticDistances(query, map, max_shift, nullptr);
  } else {
    const std::vector<int> order =
        sl::HolisticShortlist(sl::ApproximateHolisticDistances(query, map), sl::kHolisticRefine);
    const std::vector<float> measured =
        sl::HolisticDistancesTo(query, map, order, max_shift, nullptr);
    value.assign(static_cast<size_t>(map.num_images()), std::numeric_limits<float>::max());
    for (size_t i = 0; i < order.size(); ++i) value[static_cast<size_t>(order[i])] = measured[i];
  }
  for (float& v : value) v = -v;
  return value;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"place_recall: how often the coarse stage's picks hold the true place"};
  std::string map_path, cache;
  std::vector<std::string> dirs;
  std::vector<int> limits = {0, 32};
  std::vector<int> ks = {4, 8, 16, 28, 48, 96};
  app.add_option("--map", map_path, "a map with a place index")->required();
  app.add_option("--queries", dirs, "query folders (truth: the tour image of the same name)")
      ->required();
  app.add_option("--hamming", limits, "place_hamming_max values to compare (0 = plain tf-idf)");
  app.add_option("--picks", ks, "numbers of word picks to report");
  app.add_option("--cache", cache, "feature cache folder");
  CLI11_PARSE(app, argc, argv);
  std::sort(ks.begin(), ks.end());
  auto loaded = sl::LoadMap(map_path);
  if (!loaded.ok()) {
    std::fprintf(stderr, "place_recall: %s\n", loaded.status().ToString().c_str());
    return 1;
  }
  const sl::Map& map = *loaded;
  if (!map.has_place_index()) {
    std::fprintf(stderr, "place_recall: %s has no place index (it is searched whole)\n",
                 map_path.c_str());
    return 1;
  }
  const sl::ExtractionTarget frame{map.image_width, map.image_height, map.holistic_grid};
  // Rows: one per Hamming limit, then holistic exact and holistic as searched.
  std::vector<std::string> rows;
  for (int limit : limits) rows.push_back("hamming " + std::to_string(limit));
  if (!map.place_index.holistic.empty()) {
    rows.push_back("holistic exact");
    rows.push_back("holistic searched");
  }
  std::vector<std::vector<double>> mean(rows.size(), std::vector<double>(ks.size(), 0));
  for (const std::string& dir : dirs) {
    auto listed = sl::ListImageFiles(dir);
    if (!listed.ok()) {
      std::fprintf(stderr, "place_recall: %s\n", listed.status().ToString().c_str());
      return 1;
    }
    std::vector<std::string> names;
    for (const std::string& path : *listed) names.push_back(sl::FileName(path));
    auto queries = sl::ExtractCached(*listed, map.options.extractor, cache, 2, &frame);
    auto truth = sl::ResolveTruth(names, map.image_names, {});
    if (!queries.ok() || !truth.ok()) {
      std::fprintf(stderr, "place_recall: %s\n",
                   (queries.ok() ? truth.status() : queries.status()).ToString().c_str());
      return 1;
    }
    std::printf("%s (%zu queries): share with a pick within +-%d among the first K\n", dir.c_str(),
                queries->size(), kTolerance);
    for (size_t v = 0; v < rows.size(); ++v) {
      std::vector<int> hits(ks.size(), 0);
      for (size_t q = 0; q < queries->size(); ++q) {
        const sl::FeatureSet& query = (*queries)[q];
        const std::vector<float> value =
            v < limits.size() ? sl::WordScores(query, map, limits[v])
                              : HolisticValues(query, map, /*exact=*/v == limits.size());
        const int rank = PickRank(value, (*truth)[q], ks.back());
        for (size_t j = 0; j < ks.size(); ++j) hits[j] += rank > 0 && rank <= ks[j];
      }
      std::printf("  %-18s", rows[v].c_str());
      for (size_t j = 0; j < ks.size(); ++j) {
        const double share = static_cast<double>(hits[j]) / static_cast<double>(queries->size());
        mean[v][j] += share / static_cast<double>(dirs.size());
        std::printf("  K=%d %.2f", ks[j], share);
      }
      std::printf("\n");
    }
  }
  std::printf("mean over the %zu folders\n", dirs.size());
  for (size_t v = 0; v < rows.size(); ++v) {
    std::printf("  %-18s", rows[v].c_str());
    for (size_t j = 0; j < ks.size(); ++j) std::printf("  K=%d %.3f", ks[j], mean[v][j]);
    std::printf("\n");
  }
  return 0;
}
