#include "common/map/place_index.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <random>
#include <string>

#include "common/map/compact.h"

namespace sceneloc {
namespace {

bool AllFinite(const float* v, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) return false;
  }
  return true;
}

Status ValidateVocabulary(const PlaceIndex& index, size_t num_landmarks) {
  const Vocabulary& v = index.vocabulary;
  if (v.coarse < 1 || v.fine < 1 || v.coarse > 4096 || v.fine > 4096) {
    return DataLoss("place index vocabulary of " + std::to_string(v.coarse) + " x " +
                    std::to_string(v.fine) + " words is out of range");
  }
  const auto rows = static_cast<size_t>(v.coarse) * (1 + static_cast<size_t>(v.fine));
  if (static_cast<size_t>(v.centroids.rows()) != rows) {
    return DataLoss("place index vocabulary has " + std::to_string(v.centroids.rows()) +
                    " centroids, expected " + std::to_string(rows));
  }
  if (!AllFinite(v.centroids.data(), static_cast<size_t>(v.centroids.size()))) {
    return DataLoss("place index vocabulary holds a value that is not finite");
  }
  if (index.landmark_word.size() != num_landmarks) {
    return DataLoss("place index has " + std::to_string(index.landmark_word.size()) +
                    " landmark words but the map has " + std::to_string(num_landmarks) +
                    " landmarks");
  }
  for (size_t g = 0; g < num_landmarks; ++g) {
    if (index.landmark_word[g] >= static_cast<uint32_t>(v.num_words())) {
      return DataLoss("place index: landmark " + std::to_string(g) + " has word " +
                      std::to_string(index.landmark_word[g]) + " of " +
                      std::to_string(v.num_words()));
    }
  }
  return Status::Ok();
}

Status ValidateCodes(const HolisticCodes& h, size_t num_locations, const HolisticGrid& grid) {
  if (h.empty()) {
    if (!h.codes.empty()) return DataLoss("place index holds holistic codes without a codebook");
    return Status::Ok();
  }
  if (grid.empty()) return DataLoss("place index codes holistic descriptors the map lacks");
  if (h.bins != grid.bins ||
      h.codebook.size() != static_cast<size_t>(kHolisticCodes) * static_cast<size_t>(grid.bins) ||
      !AllFinite(h.codebook.data(), h.codebook.size())) {
    return DataLoss("place index holistic codebook does not fit the holistic grid");
  }
  if (h.codes.size() != num_locations * static_cast<size_t>(grid.cells())) {
    return DataLoss("place index holistic codes do not hold every location");
  }
  return Status::Ok();
}

}  // namespace

Status ValidatePlaceIndex(const PlaceIndex& index, size_t num_landmarks, size_t num_locations,
                          const HolisticGrid& grid) {
  if (index.empty()) {
    if (!index.landmark_word.empty() || !index.holistic.empty()) {
      return DataLoss("place index without a vocabulary holds other parts");
    }
    return Status::Ok();
  }
  SCENELOC_RETURN_IF_ERROR(ValidateVocabulary(index, num_landmarks));
  return ValidateCodes(index.holistic, num_locations, grid);
}

SignatureProjection MakeSignatureProjection() {
  // Random signs from a fixed seed (std::mt19937's sequence is specified), then Gram-Schmidt
  // in double: the rows are orthonormal, each a random direction.
  std::mt19937 rng(20261207);
  Eigen::Matrix<double, kSignatureBits, kDescriptorSize, Eigen::RowMajor> axes;
  for (int r = 0; r < kSignatureBits; ++r) {
    for (int c = 0; c < kDescriptorSize; ++c) axes(r, c) = (rng() & 1u) != 0 ? 1.0 : -1.0;
    for (int q = 0; q < r; ++q) axes.row(r) -= axes.row(r).dot(axes.row(q)) * axes.row(q);
    axes.row(r).normalize();
  }
  return axes.cast<float>();
}

namespace {

uint64_t SignatureOf(const float* projected, const float* thresholds) {
  uint64_t bits = 0;
  for (int k = 0; k < kSignatureBits; ++k) {
    bits |= static_cast<uint64_t>(projected[k] > thresholds[k]) << k;
  }
  return bits;
}

using ProjectedRows = Eigen::Matrix<float, Eigen::Dynamic, kSignatureBits, Eigen::RowMajor>;

}  // namespace

InvertedFile BuildInvertedFile(
    const PlaceIndex& index, const std::vector<uint32_t>& image_offsets,
    const std::vector<uint32_t>& image_landmarks,
    const Eigen::Matrix<uint8_t, Eigen::Dynamic, kDescriptorSize, Eigen::RowMajor>& means) {
  InvertedFile file;
  const size_t words = static_cast<size_t>(index.vocabulary.num_words());
  const size_t locations = image_offsets.empty() ? 0 : image_offsets.size() - 1;
  const size_t landmarks = static_cast<size_t>(means.rows());
  const std::vector<uint32_t>& word_of = index.landmark_word;

  // Word by word (a word's landmarks gathered by a counting sort): their projections, the
  // median on each axis, and their signatures. A word at a time keeps the projections of a
  // million landmarks (256 MB) from being held at once.
  file.projection = MakeSignatureProjection();
  std::vector<uint32_t> first(words + 1, 0);
  for (uint32_t w : word_of) ++first[w + 1];
  for (size_t w = 0; w < words; ++w) first[w + 1] += first[w];
  std::vector<uint32_t> members(landmarks);
  {
    std::vector<uint32_t> fill(first.begin(), first.end() - 1);
    for (size_t g = 0; g < landmarks; ++g) members[fill[word_of[g]]++] = static_cast<uint32_t>(g);
  }
  file.thresholds.assign(words * kSignatureBits, 0.0f);
  std::vector<uint64_t> landmark_signature(landmarks);
  DescriptorMatrix values;
  ProjectedRows projected;
  std::vector<float> column;
  for (size_t w = 0; w < words; ++w) {
    const auto count = static_cast<Eigen::Index>(first[w + 1] - first[w]);
    if (count == 0) continue;
    values.resize(count, kDescriptorSize);
    for (Eigen::Index i = 0; i < count; ++i) {
      values.row(i) =
          means.row(members[first[w] + static_cast<size_t>(i)]).cast<float>() * (1.0f / 255.0f);
    }
    projected.noalias() = values * file.projection.transpose();
    float* thresholds = &file.thresholds[w * kSignatureBits];
    for (int k = 0; k < kSignatureBits; ++k) {
      column.resize(static_cast<size_t>(count));
      for (Eigen::Index i = 0; i < count; ++i) column[static_cast<size_t>(i)] = projected(i, k);
      const auto middle = column.begin() + count / 2;
      std::nth_element(column.begin(), middle, column.end());
      thresholds[k] = *middle;
    }
    for (Eigen::Index i = 0; i < count; ++i) {
      landmark_signature[members[first[w] + static_cast<size_t>(i)]] =
          SignatureOf(projected.row(i).data(), thresholds);
    }
  }

  // The occurrences, word by word; per word, the locations having it; per location, its
  // tf-idf vector's norm.
  file.offsets.assign(words + 1, 0);
  std::vector<uint32_t> having(words, 0), last(words, UINT32_MAX);
  for (size_t l = 0; l < locations; ++l) {
    for (uint32_t k = image_offsets[l]; k < image_offsets[l + 1]; ++k) {
      const uint32_t w = word_of[image_landmarks[k]];
      ++file.offsets[w + 1];
      if (last[w] != l) ++having[w];
      last[w] = static_cast<uint32_t>(l);
    }
  }
  for (size_t w = 0; w < words; ++w) file.offsets[w + 1] += file.offsets[w];
  file.idf.assign(words, 0.0f);
  for (size_t w = 0; w < words; ++w) {
    if (having[w] > 0) {
      file.idf[w] = static_cast<float>(std::log(static_cast<double>(locations) / having[w]));
    }
  }
  file.location.resize(file.offsets.back());
  file.signature.resize(file.offsets.back());
  file.location_scale.assign(locations, 0.0f);
  std::vector<uint32_t> fill(file.offsets.begin(), file.offsets.end() - 1);
  std::vector<uint32_t> words_here;
  for (size_t l = 0; l < locations; ++l) {
    words_here.clear();
    for (uint32_t k = image_offsets[l]; k < image_offsets[l + 1]; ++k) {
      const uint32_t g = image_landmarks[k], w = word_of[g];
      file.location[fill[w]] = static_cast<uint32_t>(l);
      file.signature[fill[w]++] = landmark_signature[g];
      words_here.push_back(w);
    }
    std::sort(words_here.begin(), words_here.end());
    double norm = 0;
    for (size_t i = 0; i < words_here.size();) {
      size_t j = i;
      while (j < words_here.size() && words_here[j] == words_here[i]) ++j;
      norm += std::pow(static_cast<double>(j - i) * file.idf[words_here[i]], 2.0);
      i = j;
    }
    if (norm > 0) file.location_scale[l] = static_cast<float>(1.0 / std::sqrt(norm));
  }
  return file;
}

std::vector<uint64_t> Signatures(const InvertedFile& file, const DescriptorMatrix& descriptors,
                                 const std::vector<uint32_t>& words) {
  const ProjectedRows projected = descriptors * file.projection.transpose();
  std::vector<uint64_t> out(words.size());
  for (size_t i = 0; i < words.size(); ++i) {
    out[i] = SignatureOf(projected.row(static_cast<Eigen::Index>(i)).data(),
                         &file.thresholds[static_cast<size_t>(words[i]) * kSignatureBits]);
  }
  return out;
}

namespace {

// Index of the nearest of `centres` for each row of `x`: |c|^2 - 2 x.c smallest.
template <typename Rows, typename Centres>
std::vector<uint32_t> Nearest(const Eigen::MatrixBase<Rows>& x,
                              const Eigen::MatrixBase<Centres>& centres) {
  const Eigen::VectorXf c2 = centres.rowwise().squaredNorm();
  const Eigen::MatrixXf dots = centres * x.transpose();  // centres x rows
  std::vector<uint32_t> out(static_cast<size_t>(x.rows()));
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    Eigen::Index best = 0;
    (c2 - 2.0f * dots.col(i)).minCoeff(&best);
    out[static_cast<size_t>(i)] = static_cast<uint32_t>(best);
  }
  return out;
}

// Cells the holistic codebook is fitted on, at most (sampled evenly), and its rounds.
constexpr size_t kCodebookSamples = 65536;
constexpr int kCodebookIterations = 10;

// Cells [begin, end) of `holistic` (unit bytes, `bins` a cell) as values.
RowMatrix CellValues(const std::vector<uint8_t>& holistic, int bins, size_t begin, size_t end) {
  RowMatrix x(static_cast<Eigen::Index>(end - begin), bins);
  for (size_t c = begin; c < end; ++c) {
    for (int b = 0; b < bins; ++b) {
      x(static_cast<Eigen::Index>(c - begin), b) =
          UnitValue(holistic[c * static_cast<size_t>(bins) + static_cast<size_t>(b)]);
    }
  }
  return x;
}

}  // namespace

RowMatrix KMeans(const RowMatrix& x, int k, int iterations, std::mt19937* rng) {
  const auto n = static_cast<size_t>(x.rows());
  std::vector<Eigen::Index> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), *rng);
  RowMatrix centres(k, x.cols());
  for (int c = 0; c < k; ++c) centres.row(c) = x.row(order[static_cast<size_t>(c)]);
  const Eigen::VectorXf x2 = x.rowwise().squaredNorm();
  std::vector<int> assigned(n);
  std::vector<float> distance(n);
  for (int iteration = 0; iteration < iterations; ++iteration) {
    const Eigen::VectorXf c2 = centres.rowwise().squaredNorm();
    const Eigen::MatrixXf dots = centres * x.transpose();
    for (size_t i = 0; i < n; ++i) {
      Eigen::Index best = 0;
      const float d = (c2 - 2.0f * dots.col(static_cast<Eigen::Index>(i))).minCoeff(&best);
      assigned[i] = static_cast<int>(best);
      distance[i] = d + x2[static_cast<Eigen::Index>(i)];
    }
    RowMatrix sums = RowMatrix::Zero(k, x.cols());
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

HolisticCodes CodeHolistic(const std::vector<uint8_t>& holistic, const HolisticGrid& grid, size_t n,
                           ThreadPool* pool) {
  HolisticCodes h;
  const size_t cells = n * static_cast<size_t>(grid.cells());
  if (grid.empty() || cells == 0) return h;
  h.bins = grid.bins;
  // The codebook from evenly sampled cells; a tour of fewer distinct cells than codes
  // repeats them (the spare codes are never nearest).
  const size_t samples = std::min(cells, kCodebookSamples);
  RowMatrix sample(static_cast<Eigen::Index>(samples), grid.bins);
  for (size_t i = 0; i < samples; ++i) {
    sample.row(static_cast<Eigen::Index>(i)) =
        CellValues(holistic, grid.bins, i * cells / samples, i * cells / samples + 1);
  }
  RowMatrix codebook(kHolisticCodes, grid.bins);
  if (samples >= static_cast<size_t>(kHolisticCodes)) {
    std::mt19937 rng(20261208);
    codebook = KMeans(sample, kHolisticCodes, kCodebookIterations, &rng);
  } else {
    for (int c = 0; c < kHolisticCodes; ++c)
      codebook.row(c) = sample.row(c % static_cast<int>(samples));
  }
  h.codebook.assign(codebook.data(), codebook.data() + codebook.size());
  h.codes = CodeCells(holistic, 0, cells, h, pool);
  return h;
}

std::vector<uint8_t> CodeCells(const std::vector<uint8_t>& holistic, size_t first, size_t count,
                               const HolisticCodes& h, ThreadPool* pool) {
  const Eigen::Map<const RowMatrix> codebook(h.codebook.data(), kHolisticCodes, h.bins);
  std::vector<uint8_t> codes(count);
  constexpr size_t kCellsPerTask = 16384;
  const auto code = [&](size_t first_task, size_t end_task) {
    for (size_t t = first_task; t < end_task; ++t) {
      const size_t begin = t * kCellsPerTask, end = std::min(count, begin + kCellsPerTask);
      const std::vector<uint32_t> nearest =
          Nearest(CellValues(holistic, h.bins, first + begin, first + end), codebook);
      for (size_t c = begin; c < end; ++c) codes[c] = static_cast<uint8_t>(nearest[c - begin]);
    }
  };
  const size_t tasks = (count + kCellsPerTask - 1) / kCellsPerTask;
  if (pool != nullptr) {
    pool->ParallelFor(tasks, 1, code);
  } else {
    code(0, tasks);
  }
  return codes;
}

std::vector<uint32_t> AssignCells(const Vocabulary& v, const DescriptorMatrix& descriptors) {
  return Nearest(descriptors, v.centroids.topRows(v.coarse));
}

std::vector<uint32_t> AssignWords(const Vocabulary& v, const DescriptorMatrix& descriptors) {
  const std::vector<uint32_t> cell = AssignCells(v, descriptors);
  // Rows grouped by cell, each group against its cell's words in one product.
  std::vector<std::vector<uint32_t>> members(static_cast<size_t>(v.coarse));
  for (size_t i = 0; i < cell.size(); ++i) members[cell[i]].push_back(static_cast<uint32_t>(i));
  std::vector<uint32_t> word(cell.size());
  DescriptorMatrix group;
  for (int c = 0; c < v.coarse; ++c) {
    const std::vector<uint32_t>& rows = members[static_cast<size_t>(c)];
    if (rows.empty()) continue;
    group.resize(static_cast<Eigen::Index>(rows.size()), kDescriptorSize);
    for (size_t k = 0; k < rows.size(); ++k)
      group.row(static_cast<Eigen::Index>(k)) = descriptors.row(rows[k]);
    const std::vector<uint32_t> fine = Nearest(
        group, v.centroids.middleRows(v.coarse + static_cast<Eigen::Index>(c) * v.fine, v.fine));
    for (size_t k = 0; k < rows.size(); ++k) {
      word[rows[k]] = static_cast<uint32_t>(c) * static_cast<uint32_t>(v.fine) + fine[k];
    }
  }
  return word;
}

}  // namespace sceneloc
