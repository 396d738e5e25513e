#include "common/map/place_index.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace sceneloc {
namespace {

bool AllFinite(const float* v, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) return false;
  }
  return true;
}

// Tour cells compared at `shift`: columns [begin, begin + width).
int ShiftBegin(int shift, bool query) { return query ? std::max(0, shift) : std::max(0, -shift); }

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

Status ValidateProjection(const HolisticProjection& h, size_t num_locations,
                          const HolisticGrid& grid) {
  if (h.empty()) return Status::Ok();
  if (grid.empty()) return DataLoss("place index projects holistic descriptors the map lacks");
  if (h.dims < 1 || h.dims > 1024 || h.max_shift < 0 || h.max_shift >= grid.cols) {
    return DataLoss("place index holistic projection (" + std::to_string(h.dims) + " axes, shift " +
                    std::to_string(h.max_shift) + ") is out of range");
  }
  const size_t shifts = static_cast<size_t>(h.num_shifts());
  const size_t values = h.MeanOffset(h.num_shifts(), grid);
  if (h.mean.size() != values || h.axes.size() != values * static_cast<size_t>(h.dims) ||
      !AllFinite(h.mean.data(), h.mean.size()) || !AllFinite(h.axes.data(), h.axes.size())) {
    return DataLoss("place index holistic projection does not fit the holistic grid");
  }
  if (h.projected.size() != num_locations * shifts * static_cast<size_t>(h.dims) ||
      h.residual.size() != num_locations * shifts ||
      !AllFinite(h.projected.data(), h.projected.size()) ||
      !AllFinite(h.residual.data(), h.residual.size())) {
    return DataLoss("place index holistic projection does not hold every location");
  }
  return Status::Ok();
}

}  // namespace

size_t ShiftSpan(const HolisticGrid& grid, int shift) {
  return static_cast<size_t>(grid.rows) * static_cast<size_t>(grid.cols - std::abs(shift)) *
         static_cast<size_t>(grid.bins);
}

size_t HolisticProjection::MeanOffset(int k, const HolisticGrid& grid) const {
  size_t offset = 0;
  for (int j = 0; j < k; ++j) offset += ShiftSpan(grid, j - max_shift);
  return offset;
}

Status ValidatePlaceIndex(const PlaceIndex& index, size_t num_landmarks, size_t num_locations,
                          const HolisticGrid& grid) {
  if (index.empty()) {
    if (!index.landmark_word.empty() || !index.holistic.empty()) {
      return DataLoss("place index without a vocabulary holds other parts");
    }
    return Status::Ok();
  }
  SCENELOC_RETURN_IF_ERROR(ValidateVocabulary(index, num_landmarks));
  return ValidateProjection(index.holistic, num_locations, grid);
}

InvertedFile BuildInvertedFile(const PlaceIndex& index, const std::vector<uint32_t>& image_offsets,
                               const std::vector<uint32_t>& image_landmarks) {
  InvertedFile file;
  const size_t words = static_cast<size_t>(index.vocabulary.num_words());
  const size_t locations = image_offsets.empty() ? 0 : image_offsets.size() - 1;
  // Each location's words with their counts, sorted by word.
  std::vector<std::vector<std::pair<uint32_t, float>>> bags(locations);
  std::vector<uint32_t> having(words, 0);  // locations with each word
  std::vector<uint32_t> words_of;
  for (size_t l = 0; l < locations; ++l) {
    words_of.clear();
    for (uint32_t k = image_offsets[l]; k < image_offsets[l + 1]; ++k) {
      words_of.push_back(index.landmark_word[image_landmarks[k]]);
    }
    std::sort(words_of.begin(), words_of.end());
    for (size_t i = 0; i < words_of.size();) {
      size_t j = i;
      while (j < words_of.size() && words_of[j] == words_of[i]) ++j;
      bags[l].push_back({words_of[i], static_cast<float>(j - i)});
      ++having[words_of[i]];
      i = j;
    }
  }
  file.idf.assign(words, 0.0f);
  for (size_t w = 0; w < words; ++w) {
    if (having[w] > 0) {
      file.idf[w] = static_cast<float>(std::log(static_cast<double>(locations) / having[w]));
    }
  }
  file.offsets.assign(words + 1, 0);
  for (size_t w = 0; w < words; ++w) file.offsets[w + 1] = file.offsets[w] + having[w];
  file.location.resize(file.offsets.back());
  file.weight.resize(file.offsets.back());
  std::vector<uint32_t> fill(file.offsets.begin(), file.offsets.end() - 1);
  for (size_t l = 0; l < locations; ++l) {
    double norm = 0;
    for (const auto& [w, count] : bags[l]) norm += std::pow(count * file.idf[w], 2.0);
    const float scale = norm > 0 ? static_cast<float>(1.0 / std::sqrt(norm)) : 0.0f;
    for (const auto& [w, count] : bags[l]) {
      file.location[fill[w]] = static_cast<uint32_t>(l);
      file.weight[fill[w]++] = count * file.idf[w] * scale;
    }
  }
  return file;
}

namespace {

// Index of the nearest of `centres` for each row of `x`: |c|^2 - 2 x.c smallest.
std::vector<uint32_t> Nearest(const DescriptorMatrix& x, const DescriptorMatrix& centres) {
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

}  // namespace

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

void ShiftedCells(const float* descriptor, const HolisticGrid& grid, int shift, bool query,
                  std::vector<float>* out) {
  const int begin = ShiftBegin(shift, query);
  const int width = grid.cols - std::abs(shift);
  out->clear();
  for (int r = 0; r < grid.rows; ++r) {
    const float* row = descriptor + (static_cast<size_t>(r) * grid.cols + begin) * grid.bins;
    out->insert(out->end(), row, row + static_cast<size_t>(width) * grid.bins);
  }
}

}  // namespace sceneloc
