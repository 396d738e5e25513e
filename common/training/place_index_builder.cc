#include "common/training/place_index_builder.h"

#include <Eigen/Eigenvalues>
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
// Tour locations the holistic axes are fitted on, at most.
constexpr size_t kAxisSamples = 1024;

// Rows of `data` at `rows`.
DescriptorMatrix Gather(const DescriptorMatrix& data, const std::vector<uint32_t>& rows) {
  DescriptorMatrix out(static_cast<Eigen::Index>(rows.size()), kDescriptorSize);
  for (size_t i = 0; i < rows.size(); ++i)
    out.row(static_cast<Eigen::Index>(i)) = data.row(rows[i]);
  return out;
}

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

// Lloyd's k-means of the rows of `x` into k centres (k <= rows), seeded by k distinct rows
// drawn with `rng`; an emptied centre is moved to the row furthest from its own.
DescriptorMatrix KMeans(const DescriptorMatrix& x, int k, std::mt19937* rng) {
  const auto n = static_cast<size_t>(x.rows());
  std::vector<uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), *rng);
  order.resize(static_cast<size_t>(k));
  DescriptorMatrix centres = Gather(x, order);
  const Eigen::VectorXf x2 = x.rowwise().squaredNorm();
  std::vector<int> assigned(n);
  std::vector<float> distance(n);
  for (int iteration = 0; iteration < kKMeansIterations; ++iteration) {
    const Eigen::VectorXf c2 = centres.rowwise().squaredNorm();
    const Eigen::MatrixXf dots = centres * x.transpose();
    for (size_t i = 0; i < n; ++i) {
      Eigen::Index best = 0;
      const float d = (c2 - 2.0f * dots.col(static_cast<Eigen::Index>(i))).minCoeff(&best);
      assigned[i] = static_cast<int>(best);
      distance[i] = d + x2[static_cast<Eigen::Index>(i)];
    }
    DescriptorMatrix sums = DescriptorMatrix::Zero(k, kDescriptorSize);
    std::vector<int> counts(static_cast<size_t>(k), 0);
    for (size_t i = 0; i < n; ++i) {
      sums.row(assigned[i]) += x.row(static_cast<Eigen::Index>(i));
      ++counts[static_cast<size_t>(assigned[i])];
    }
    for (int c = 0; c < k; ++c) {
      if (counts[static_cast<size_t>(c)] > 0) {
        centres.row(c) = sums.row(c) / static_cast<float>(counts[static_cast<size_t>(c)]);
        continue;
      }
      const auto far = static_cast<size_t>(std::max_element(distance.begin(), distance.end()) -
                                           distance.begin());
      centres.row(c) = x.row(static_cast<Eigen::Index>(far));
      distance[far] = 0;
    }
  }
  return centres;
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
  v.centroids.topRows(side) = KMeans(sample, side, &rng);
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
        fine = KMeans(x, side, &cell_rng);
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

// The axes of one shift from the sampled locations' centred values (a Gram matrix of at
// most kAxisSamples rows), then every location's projection and residual.
void ProjectShift(const Map& map, int k, HolisticProjection* h) {
  const int shift = k - h->max_shift;
  const HolisticGrid& grid = map.holistic_grid;
  const auto span = static_cast<Eigen::Index>(ShiftSpan(grid, shift));
  const size_t n = static_cast<size_t>(map.num_images());
  Eigen::MatrixXf values(static_cast<Eigen::Index>(n), span);
  std::vector<float> cells;
  for (size_t l = 0; l < n; ++l) {
    ShiftedCells(map.HolisticValues(static_cast<int>(l)).data(), grid, shift, /*query=*/false,
                 &cells);
    values.row(static_cast<Eigen::Index>(l)) =
        Eigen::Map<const Eigen::RowVectorXf>(cells.data(), span);
  }
  const Eigen::RowVectorXf mean = values.colwise().mean();
  values.rowwise() -= mean;
  const std::vector<uint32_t> rows = EvenSample(n, kAxisSamples);
  Eigen::MatrixXd sample(static_cast<Eigen::Index>(rows.size()), span);
  for (size_t i = 0; i < rows.size(); ++i) {
    sample.row(static_cast<Eigen::Index>(i)) = values.row(rows[i]).cast<double>();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(sample * sample.transpose());
  const int dims = h->dims;
  Eigen::MatrixXf axes = Eigen::MatrixXf::Zero(dims, span);
  for (int a = 0; a < dims && a < sample.rows(); ++a) {
    const Eigen::Index column = sample.rows() - 1 - a;  // eigenvalues come in increasing order
    const double value = solver.eigenvalues()[column];
    if (!(value > 1e-12)) break;  // fewer distinct locations than axes: the rest stay zero
    axes.row(a) = (sample.transpose() * solver.eigenvectors().col(column) / std::sqrt(value))
                      .cast<float>()
                      .transpose();
  }
  const size_t offset = h->MeanOffset(k, grid);
  std::copy(mean.data(), mean.data() + span, h->mean.begin() + static_cast<std::ptrdiff_t>(offset));
  // Row-major copy: axes.row(a) of a column-major matrix is strided.
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> axes_rows = axes;
  std::copy(axes_rows.data(), axes_rows.data() + axes_rows.size(),
            h->axes.begin() + static_cast<std::ptrdiff_t>(offset * dims));
  const Eigen::MatrixXf projected = values * axes.transpose();  // n x dims
  const int shifts = h->num_shifts();
  for (size_t l = 0; l < n; ++l) {
    const auto row = static_cast<Eigen::Index>(l);
    float* out = h->projected.data() + (l * shifts + k) * dims;
    for (int a = 0; a < dims; ++a) out[a] = projected(row, a);
    h->residual[l * shifts + k] =
        std::max(0.0f, values.row(row).squaredNorm() - projected.row(row).squaredNorm());
  }
}

void BuildHolisticProjection(Map* map, ThreadPool* pool) {
  HolisticProjection& h = map->place_index.holistic;
  h = HolisticProjection();
  if (!map->has_holistic()) return;
  const HolisticGrid& grid = map->holistic_grid;
  h.max_shift = std::clamp(map->options.extractor.holistic.max_shift, 0, grid.cols - 1);
  h.dims = map->options.place_index_dims;
  const int shifts = h.num_shifts();
  const size_t values = h.MeanOffset(shifts, grid);
  h.mean.assign(values, 0.0f);
  h.axes.assign(values * static_cast<size_t>(h.dims), 0.0f);
  const size_t n = static_cast<size_t>(map->num_images());
  h.projected.assign(n * static_cast<size_t>(shifts) * h.dims, 0.0f);
  h.residual.assign(n * static_cast<size_t>(shifts), 0.0f);
  auto run = [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) ProjectShift(*map, static_cast<int>(k), &h);
  };
  if (pool != nullptr) {
    pool->ParallelFor(static_cast<size_t>(shifts), 1, run);
  } else {
    run(0, static_cast<size_t>(shifts));
  }
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
  BuildHolisticProjection(map, pool);
}

}  // namespace sceneloc
