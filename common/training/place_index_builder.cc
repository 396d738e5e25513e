#include "common/training/place_index_builder.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

namespace sceneloc {
namespace {

constexpr int kKMeansIterations = 10;
// Landmarks the coarse cells are fitted on, at most (sampled evenly); every landmark of a
// cell fits its words, at most kFineSamples of them.
constexpr size_t kCoarseSamples = 65536;
constexpr size_t kFineSamples = 8192;

// At most `limit` of [0, n), evenly spaced.
std::vector<uint32_t> EvenSample(size_t n, size_t limit) {
  std::vector<uint32_t> out;
  const size_t count = std::min(n, limit);
  for (size_t i = 0; i < count; ++i) out.push_back(static_cast<uint32_t>(i * n / count));
  return out;
}

// The local means of landmarks `rows` as values.
DescriptorMatrix GatherMeans(const Map& map, const std::vector<uint32_t>& rows) {
  DescriptorMatrix out(static_cast<Eigen::Index>(rows.size()), kDescriptorSize);
  for (size_t i = 0; i < rows.size(); ++i) {
    map.LocalMean(static_cast<int>(rows[i]), out.row(static_cast<Eigen::Index>(i)).data());
  }
  return out;
}

// `assign` (AssignCells or AssignWords) over every landmark's mean, a block at a time.
using AssignFn = std::vector<uint32_t> (*)(const Vocabulary&, const DescriptorMatrix&);
std::vector<uint32_t> AssignLandmarks(const Vocabulary& v, const Map& map, AssignFn assign) {
  constexpr size_t kBlock = 65536;
  const size_t n = static_cast<size_t>(map.num_landmarks());
  std::vector<uint32_t> words, rows;
  words.reserve(n);
  for (size_t begin = 0; begin < n; begin += kBlock) {
    rows.clear();
    for (size_t g = begin; g < std::min(n, begin + kBlock); ++g) {
      rows.push_back(static_cast<uint32_t>(g));
    }
    const std::vector<uint32_t> block = assign(v, GatherMeans(map, rows));
    words.insert(words.end(), block.begin(), block.end());
  }
  return words;
}

void BuildVocabulary(Map* map, ThreadPool* pool) {
  const size_t n = static_cast<size_t>(map->num_landmarks());
  const int side = VocabularySide(n);
  Vocabulary& v = map->place_index.vocabulary;
  v.coarse = side;
  v.fine = side;
  v.centroids.resize(static_cast<Eigen::Index>(side) * (1 + side), kDescriptorSize);
  std::mt19937 rng(20261206);
  const DescriptorMatrix sample = GatherMeans(*map, EvenSample(n, kCoarseSamples));
  v.centroids.topRows(side) = KMeans(sample, side, kKMeansIterations, &rng);
  // Each cell's words from its own landmarks (all of the map's, sampled), the cells in
  // parallel with a seed each.
  const std::vector<uint32_t> cell_of = AssignLandmarks(v, *map, AssignCells);
  std::vector<std::vector<uint32_t>> members(static_cast<size_t>(side));
  for (size_t g = 0; g < n; ++g) members[cell_of[g]].push_back(static_cast<uint32_t>(g));
  auto fit = [&](size_t begin, size_t end) {
    for (size_t c = begin; c < end; ++c) {
      std::vector<uint32_t> rows = members[c];
      auto fine = v.centroids.middleRows(side + static_cast<Eigen::Index>(c) * side, side);
      if (rows.empty()) {
        fine = v.centroids.row(static_cast<Eigen::Index>(c)).replicate(side, 1);
        continue;
      }
      std::vector<uint32_t> picked;
      for (uint32_t i : EvenSample(rows.size(), kFineSamples)) picked.push_back(rows[i]);
      DescriptorMatrix x = GatherMeans(*map, picked);
      // A cell with fewer landmarks than words repeats them: its spare words stay empty.
      std::mt19937 cell_rng(static_cast<uint32_t>(c) * 7919u + 1);
      if (x.rows() >= side) {
        fine = KMeans(x, side, kKMeansIterations, &cell_rng);
      } else {
        for (int w = 0; w < side; ++w) fine.row(w) = x.row(w % x.rows());
      }
    }
  };
  if (pool != nullptr) {
    pool->ParallelFor(members.size(), 1, fit);
  } else {
    fit(0, members.size());
  }
  map->place_index.landmark_word = AssignLandmarks(v, *map, AssignWords);
}

}  // namespace

int VocabularySide(size_t num_landmarks) {
  const double side = std::sqrt(static_cast<double>(num_landmarks) / 16.0);
  return static_cast<int>(std::clamp(std::lround(side), 8L, 128L));
}

void BuildPlaceIndex(Map* map, ThreadPool* pool) {
  map->place_index = PlaceIndex();
  const int min_locations = map->options.place_index_min_locations;
  if (min_locations == 0 || map->num_images() < min_locations || map->num_landmarks() == 0) return;
  BuildVocabulary(map, pool);
  map->place_index.holistic =
      CodeHolistic(map->holistic, map->holistic_grid, static_cast<size_t>(map->num_images()), pool);
}

}  // namespace sceneloc
