#include "common/map/map.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "common/map/places.h"

namespace sceneloc {
namespace {

// What a stored float must satisfy besides being finite.
enum class Range { kAny, kPositive, kNonNegative, kUnitInterval };

bool InRange(float v, Range range) {
  if (!std::isfinite(v)) return false;
  switch (range) {
    case Range::kAny:
      return true;
    case Range::kPositive:
      return v > 0.0f;
    case Range::kNonNegative:
      return v >= 0.0f;
    case Range::kUnitInterval:
      return v >= 0.0f && v <= 1.0f;
  }
  return false;
}

const char* Describe(Range range) {
  switch (range) {
    case Range::kAny:
      return "finite";
    case Range::kPositive:
      return "finite and > 0";
    case Range::kNonNegative:
      return "finite and >= 0";
    case Range::kUnitInterval:
      return "in [0, 1]";
  }
  return "";
}

std::string FormatFloat(float v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// InRange without branches, so the compiler vectorises the loop: a map holds millions
// of floats and is validated on every load.
template <Range kRange>
bool AllInRange(const float* data, size_t n) {
  constexpr float kMax = std::numeric_limits<float>::max();
  bool ok = true;
  for (size_t i = 0; i < n; ++i) {
    const float v = data[i];
    ok &= std::fabs(v) <= kMax;  // false for NaN and infinities
    if constexpr (kRange == Range::kPositive) ok &= v > 0.0f;
    if constexpr (kRange == Range::kNonNegative) ok &= v >= 0.0f;
    if constexpr (kRange == Range::kUnitInterval) ok &= (v >= 0.0f) & (v <= 1.0f);
  }
  return ok;
}

bool AllInRange(const float* data, size_t n, Range range) {
  switch (range) {
    case Range::kAny:
      return AllInRange<Range::kAny>(data, n);
    case Range::kPositive:
      return AllInRange<Range::kPositive>(data, n);
    case Range::kNonNegative:
      return AllInRange<Range::kNonNegative>(data, n);
    case Range::kUnitInterval:
      return AllInRange<Range::kUnitInterval>(data, n);
  }
  return false;
}

// Checks n values laid out as rows of `per_row`; names the first bad one as
// "name[row]" or "name[row][column]".
Status CheckValues(const char* name, const float* data, size_t n, size_t per_row, Range range) {
  if (AllInRange(data, n, range)) return Status::Ok();
  for (size_t i = 0; i < n; ++i) {
    if (InRange(data[i], range)) continue;
    std::string where = std::string(name) + "[" + std::to_string(i / per_row) + "]";
    if (per_row > 1) where += "[" + std::to_string(i % per_row) + "]";
    return DataLoss(where + " is " + FormatFloat(data[i]) + ", must be " + Describe(range));
  }
  return Status::Ok();
}

Status CheckVector(const char* name, const std::vector<float>& v, Range range) {
  return CheckValues(name, v.data(), v.size(), 1, range);
}

// Context spread codes that must be positive: every code decodes to a finite value >= 0,
// so only code 0 (the value 0) can be wrong. Scans the bytes, decoding nothing.
Status CheckPositiveCodes(const char* name, const HistogramCodes& m) {
  const uint8_t* begin = m.data();
  const uint8_t* zero = std::find(begin, begin + m.size(), uint8_t{0});
  if (zero == begin + m.size()) return Status::Ok();
  const auto i = static_cast<size_t>(zero - begin);
  return DataLoss(std::string(name) + "[" + std::to_string(i / kNumHistograms) + "][" +
                  std::to_string(i % kNumHistograms) + "] is 0, must be " +
                  Describe(Range::kPositive));
}

Status CheckCount(const char* name, size_t size, size_t expected, const char* what) {
  if (size == expected) return Status::Ok();
  return DataLoss(std::string(name) + " has " + std::to_string(size) + " entries but the map has " +
                  std::to_string(expected) + " " + what);
}

// Checks a CSR offsets array over `count` owners (`owners` names them) for an entries
// array of `num_entries`: count + 1 offsets, starting at 0, non-decreasing, ending at
// num_entries.
Status CheckCsr(const char* name, const std::vector<uint32_t>& offsets, size_t count,
                const char* owners, const char* entries_name, size_t num_entries) {
  if (offsets.size() != count + 1) {
    return DataLoss(std::string(name) + " has " + std::to_string(offsets.size()) +
                    " entries, expected " + std::to_string(count + 1) + " (" + owners + " + 1)");
  }
  if (offsets[0] != 0) {
    return DataLoss(std::string(name) + " starts at " + std::to_string(offsets[0]) +
                    ", expected 0");
  }
  for (size_t i = 0; i < count; ++i) {
    if (offsets[i + 1] >= offsets[i]) continue;
    return DataLoss(std::string(name) + " decreases after entry " + std::to_string(i) + " (" +
                    std::to_string(offsets[i]) + " then " + std::to_string(offsets[i + 1]) + ")");
  }
  if (offsets[count] == num_entries) return Status::Ok();
  return DataLoss(std::string(name) + " ends at " + std::to_string(offsets[count]) + " but " +
                  entries_name + " has " + std::to_string(num_entries) + " entries");
}

// Checks that every entry of a CSR structure refers to an index below `limit`.
// index_of(j) is entry j's index. REQUIRES: CheckCsr passed.
template <typename IndexOf>
Status CheckIndices(const std::vector<uint32_t>& offsets, IndexOf index_of, size_t limit,
                    const char* entry, const char* owner, const char* target, const char* targets) {
  for (size_t i = 0; i + 1 < offsets.size(); ++i) {
    for (uint32_t j = offsets[i]; j < offsets[i + 1]; ++j) {
      const uint32_t index = index_of(j);
      if (index < limit) continue;
      return DataLoss(std::string(entry) + " " + std::to_string(j - offsets[i]) + " of " + owner +
                      " " + std::to_string(i) + " refers to " + target + " " +
                      std::to_string(index) + " but the map has " + std::to_string(limit) + " " +
                      targets);
    }
  }
  return Status::Ok();
}

Status ValidateImages(const Map& map) {
  if (map.image_names.empty()) return DataLoss("the map has no tour images");
  for (size_t i = 0; i < map.image_names.size(); ++i) {
    if (map.image_names[i].empty())
      return DataLoss("image_names[" + std::to_string(i) + "] is empty");
  }
  if (map.image_width < kMinImageSide || map.image_height < kMinImageSide ||
      map.image_width > map.options.extractor.max_image_side ||
      map.image_height > map.options.extractor.max_image_side) {
    return DataLoss("image size " + std::to_string(map.image_width) + "x" +
                    std::to_string(map.image_height) + " must be in [" +
                    std::to_string(kMinImageSide) + ", max_image_side] per side");
  }
  return Status::Ok();
}

Status ValidateCalibration(const Map& map) {
  const Calibration& c = map.calibration;
  if (!c.valid) return Status::Ok();
  if (!map.has_holistic()) return DataLoss("calibration present in a map without holistic data");
  if (!(std::isfinite(c.off_map_distance) && c.off_map_distance >= 0 &&
        std::isfinite(c.off_map_spread) && c.off_map_spread > 0)) {
    return DataLoss("calibration off_map_distance " + FormatFloat(c.off_map_distance) +
                    " / spread " + FormatFloat(c.off_map_spread) + " out of range");
  }
  return Status::Ok();
}

Status ValidateHolistic(const Map& map) {
  const HolisticGrid& g = map.holistic_grid;
  if (g.cols == 0 && g.rows == 0 && g.bins == 0 && map.holistic.empty()) return Status::Ok();
  if (g.cols < 1 || g.rows < 1 || g.bins < 1 || g.cols > 64 || g.rows > 256 || g.bins > 36) {
    return DataLoss("holistic grid " + std::to_string(g.cols) + "x" + std::to_string(g.rows) + "x" +
                    std::to_string(g.bins) + " is out of range");
  }
  SCENELOC_RETURN_IF_ERROR(CheckCount("holistic", map.holistic.size(),
                                      map.image_names.size() * static_cast<size_t>(g.size()),
                                      "images x holistic grid values"));
  return Status::Ok();  // bytes: every value is in [0, 1]
}

// Every per-landmark array holds L entries (rows for the matrices).
Status ValidateLandmarkCounts(const Map& map) {
  const size_t l = static_cast<size_t>(map.local_mean.rows());
  const char* kWhat = "landmarks";
  SCENELOC_RETURN_IF_ERROR(CheckCount("local_dmax", map.local_dmax.size(), l, kWhat));
  SCENELOC_RETURN_IF_ERROR(CheckCount("local_var", map.local_var.size(), l, kWhat));
  SCENELOC_RETURN_IF_ERROR(CheckCount("context_mean", map.context_mean.rows(), l, kWhat));
  SCENELOC_RETURN_IF_ERROR(CheckCount("context_dmax", map.context_dmax.rows(), l, kWhat));
  SCENELOC_RETURN_IF_ERROR(CheckCount("context_var", map.context_var.rows(), l, kWhat));
  return CheckCount("quality", map.quality.size(), l, kWhat);
}

Status ValidateObservations(const Map& map) {
  const size_t l = static_cast<size_t>(map.num_landmarks());
  const size_t n = map.observation_image.size();
  SCENELOC_RETURN_IF_ERROR(CheckCsr("observation_offsets", map.observation_offsets, l, "landmarks",
                                    "observation_image", n));
  SCENELOC_RETURN_IF_ERROR(CheckCount("observations", map.observations.size(), n, "observations"));
  return CheckIndices(
      map.observation_offsets, [&](uint32_t j) { return map.observation_image[j]; },
      map.image_names.size(), "observation", "landmark", "image", "images");
}

Status ValidateNeighbourLinks(const Map& map) {
  const size_t l = static_cast<size_t>(map.num_landmarks());
  SCENELOC_RETURN_IF_ERROR(CheckCsr("neighbour_offsets", map.neighbour_offsets, l, "landmarks",
                                    "neighbours", map.neighbours.size()));
  return CheckIndices(
      map.neighbour_offsets, [&](uint32_t j) { return map.neighbours[j].landmark; }, l, "neighbour",
      "landmark", "landmark", "landmarks");
}

Status ValidateImageLandmarks(const Map& map) {
  SCENELOC_RETURN_IF_ERROR(CheckCsr("image_offsets", map.image_offsets, map.image_names.size(),
                                    "images", "image_landmarks", map.image_landmarks.size()));
  return CheckIndices(
      map.image_offsets, [&](uint32_t j) { return map.image_landmarks[j]; },
      static_cast<size_t>(map.num_landmarks()), "landmark", "image", "landmark", "landmarks");
}

Status ValidateLandmarkValues(const Map& map) {
  // The mean descriptors are bytes: any value is a valid one.
  SCENELOC_RETURN_IF_ERROR(CheckVector("local_dmax", map.local_dmax, Range::kNonNegative));
  SCENELOC_RETURN_IF_ERROR(CheckVector("local_var", map.local_var, Range::kPositive));
  // Every d_max code is a value >= 0; a variance's code must not be 0.
  SCENELOC_RETURN_IF_ERROR(CheckPositiveCodes("context_var", map.context_var));
  SCENELOC_RETURN_IF_ERROR(CheckVector("quality", map.quality, Range::kAny));
  // Positions and orientations are fixed point: any value is a valid one.
  for (size_t o = 0; o < map.observations.size(); ++o) {
    const float size = map.ObservationSize(o);
    if (!InRange(size, Range::kPositive)) {
      return DataLoss("observation_size[" + std::to_string(o) + "] is " + FormatFloat(size) +
                      ", must be " + Describe(Range::kPositive));
    }
  }
  return Status::Ok();
}

// The neighbour fields checked by value; `landmark` is checked as an index.
struct NeighbourField {
  const char* name;
  float Neighbour::*member;
  Range range;
};
constexpr NeighbourField kNeighbourFields[] = {
    {"cooccurrence", &Neighbour::cooccurrence, Range::kUnitInterval},
    {"distance_mean", &Neighbour::distance_mean, Range::kNonNegative},
    {"distance_var", &Neighbour::distance_var, Range::kPositive},
    {"distance_dmax", &Neighbour::distance_dmax, Range::kNonNegative},
    {"angle_mean", &Neighbour::angle_mean, Range::kAny},
    {"angle_var", &Neighbour::angle_var, Range::kPositive},
    {"angle_dmax", &Neighbour::angle_dmax, Range::kNonNegative},
};

Status ValidateNeighbourValues(const Map& map) {
  for (size_t j = 0; j < map.neighbours.size(); ++j) {
    const Neighbour n = map.NeighbourAt(j);
    for (const NeighbourField& field : kNeighbourFields) {
      const float v = n.*field.member;
      if (InRange(v, field.range)) continue;
      return DataLoss("neighbours[" + std::to_string(j) + "]." + field.name + " is " +
                      FormatFloat(v) + ", must be " + Describe(field.range));
    }
  }
  return Status::Ok();
}

template <typename T>
size_t VectorBytes(const std::vector<T>& v) {
  return v.capacity() * sizeof(T);
}

template <typename Matrix>
size_t MatrixBytes(const Matrix& m) {
  return static_cast<size_t>(m.size()) * sizeof(typename Matrix::Scalar);
}

// Look-alikes: none, or a CSR over the images naming other images, with ratios in (0, 1].
Status ValidateLookAlikes(const Map& m) {
  if (m.lookalike_offsets.empty()) {
    if (!m.lookalike_location.empty() || !m.lookalike_ratio.empty()) {
      return DataLoss("look-alikes without their offsets");
    }
    return Status::Ok();
  }
  const size_t n = CountPlaces(m);
  if (m.lookalike_offsets.size() != n + 1 || m.lookalike_offsets.front() != 0 ||
      m.lookalike_offsets.back() != m.lookalike_location.size() ||
      m.lookalike_ratio.size() != m.lookalike_location.size() ||
      !std::is_sorted(m.lookalike_offsets.begin(), m.lookalike_offsets.end())) {
    return DataLoss("look-alike lists do not match the places");
  }
  for (size_t i = 0; i < m.lookalike_location.size(); ++i) {
    if (m.lookalike_location[i] >= n || !(m.lookalike_ratio[i] > 0.0f) ||
        !(m.lookalike_ratio[i] <= 1.0f)) {
      return DataLoss("look-alike " + std::to_string(i) + " names no place or its ratio " +
                      "is outside (0, 1]");
    }
  }
  return Status::Ok();
}

}  // namespace

Status Map::Validate() const {
  Status options_status = options.Validate();
  if (!options_status.ok()) return DataLoss("training options: " + options_status.message());
  SCENELOC_RETURN_IF_ERROR(ValidateImages(*this));
  SCENELOC_RETURN_IF_ERROR(ValidatePlaces(*this));
  SCENELOC_RETURN_IF_ERROR(ValidateHolistic(*this));
  SCENELOC_RETURN_IF_ERROR(ValidateCalibration(*this));
  SCENELOC_RETURN_IF_ERROR(ValidateLandmarkCounts(*this));
  SCENELOC_RETURN_IF_ERROR(ValidateObservations(*this));
  SCENELOC_RETURN_IF_ERROR(ValidateNeighbourLinks(*this));
  SCENELOC_RETURN_IF_ERROR(ValidateImageLandmarks(*this));
  SCENELOC_RETURN_IF_ERROR(ValidateLandmarkValues(*this));
  SCENELOC_RETURN_IF_ERROR(ValidateNeighbourValues(*this));
  SCENELOC_RETURN_IF_ERROR(ValidateLookAlikes(*this));
  return ValidatePlaceIndex(place_index, static_cast<size_t>(num_landmarks()), image_names.size(),
                            holistic_grid);
}

std::vector<float> Map::HolisticValues(int image) const {
  const uint8_t* bytes = holistic_of(image);
  std::vector<float> values(static_cast<size_t>(holistic_grid.size()));
  for (size_t i = 0; i < values.size(); ++i) values[i] = UnitValue(bytes[i]);
  return values;
}

void Map::LocalMean(int g, float* out) const {
  const uint8_t* row = local_mean.row(g).data();
  for (int i = 0; i < kDescriptorSize; ++i) out[i] = UnitValue(row[i]);
}

void Map::ContextMean(int g, float* out) const {
  const uint8_t* row = context_mean.row(g).data();
  for (int i = 0; i < kDescriptorSize; ++i) out[i] = UnitValue(row[i]);
}

void Map::Finalize() {
  DerivePlaces(this);
  const Eigen::Index l = local_mean.rows();
  constexpr Eigen::Index kBlock = 4096;
  // The means as values, a block at a time (a big map's would be 512 bytes a landmark).
  DescriptorMatrix values;
  const auto block_of = [&](Eigen::Index begin, Eigen::Index rows) {
    values = local_mean.middleRows(begin, rows).cast<float>() * (1.0f / 255.0f);
  };
  local_mean_sqnorm.resize(static_cast<size_t>(l));
  for (Eigen::Index begin = 0; begin < l; begin += kBlock) {
    const Eigen::Index rows = std::min(kBlock, l - begin);
    block_of(begin, rows);
    Eigen::Map<Eigen::VectorXf>(local_mean_sqnorm.data() + begin, rows) =
        values.rowwise().squaredNorm();
  }

  // The principal axes of the means' second moment, accumulated in double a block at a time
  // over at most kMomentSamples landmarks, evenly spaced (a 128 x 128 eigenproblem; the axes
  // only need to be good, and a map of a million landmarks must load in seconds). With no
  // landmarks any orthonormal basis would do.
  constexpr Eigen::Index kMomentSamples = 1 << 17;
  const Eigen::Index stride = std::max<Eigen::Index>(1, (l + kMomentSamples - 1) / kMomentSamples);
  Eigen::MatrixXd moment = Eigen::MatrixXd::Identity(kDescriptorSize, kDescriptorSize);
  if (l > 0) moment.setZero();
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> block;
  for (Eigen::Index begin = 0; begin < l; begin += kBlock * stride) {
    const Eigen::Index rows = std::min(kBlock, (l - begin + stride - 1) / stride);
    block.resize(rows, kDescriptorSize);
    for (Eigen::Index r = 0; r < rows; ++r) {
      block.row(r) = local_mean.row(begin + r * stride).cast<double>() * (1.0 / 255.0);
    }
    moment.noalias() += block.transpose() * block;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(moment);
  // Eigenvalues come in increasing order: the last kBoundDims columns are the axes.
  local_basis = solver.eigenvectors().rightCols(kBoundDims).cast<float>();
  local_projected.resize(0, kBoundDims);
  local_projected_sqnorm.clear();
  local_residual_norm.clear();
  if (keeps_projections()) {
    local_projected.resize(l, kBoundDims);
    local_projected_sqnorm.resize(static_cast<size_t>(l));
    local_residual_norm.resize(static_cast<size_t>(l));
    for (Eigen::Index begin = 0; begin < l; begin += kBlock) {
      const Eigen::Index rows = std::min(kBlock, l - begin);
      block_of(begin, rows);
      ProjectBlock(values, local_basis, &local_projected, begin, &local_projected_sqnorm,
                   &local_residual_norm);
    }
  }
  inverted_file = has_place_index()
                      ? BuildInvertedFile(place_index, image_offsets, image_landmarks, local_mean)
                      : InvertedFile();
  // A map of format versions 4-7 has a place index without holistic codes.
  if (has_place_index() && has_holistic() && place_index.holistic.empty()) {
    place_index.holistic =
        CodeHolistic(holistic, holistic_grid, static_cast<size_t>(num_images()), nullptr);
  }
}

void ProjectBlock(const DescriptorMatrix& means,
                  const Eigen::Matrix<float, kDescriptorSize, kBoundDims>& basis,
                  ProjectedMatrix* projected, Eigen::Index at, std::vector<float>* sqnorm,
                  std::vector<float>* residual_norm) {
  const Eigen::Index rows = means.rows();
  projected->middleRows(at, rows).noalias() = means * basis;
  // The residuals directly (|mu|^2 - |P^T mu|^2 would cancel).
  const DescriptorMatrix residual = means - projected->middleRows(at, rows) * basis.transpose();
  for (Eigen::Index r = 0; r < rows; ++r) {
    (*sqnorm)[static_cast<size_t>(at + r)] = projected->row(at + r).squaredNorm();
    (*residual_norm)[static_cast<size_t>(at + r)] = residual.row(r).norm();
  }
}

std::array<float, 2> Map::MeanPosition(int g) const {
  const uint32_t begin = observation_offsets[g], end = observation_offsets[g + 1];
  double x = 0, y = 0;
  for (uint32_t o = begin; o < end; ++o) {
    x += ObservationX(o);
    y += ObservationY(o);
  }
  const double n = std::max<uint32_t>(1, end - begin);
  return {static_cast<float>(x / n), static_cast<float>(y / n)};
}

size_t Map::MemoryBytes() const {
  size_t bytes = sizeof(Map) + provenance.tour_dir.capacity() + provenance.created_utc.capacity() +
                 provenance.tool_version.capacity();
  bytes += VectorBytes(image_names) + VectorBytes(holistic) + VectorBytes(image_place) +
           VectorBytes(place_image) + VectorBytes(experiences);
  for (const Experience& e : experiences) {
    bytes += e.name.capacity() + e.source_dir.capacity() + e.created_utc.capacity();
  }
  for (const std::string& name : image_names) bytes += name.capacity();
  bytes += MatrixBytes(local_mean) + MatrixBytes(context_mean) + MatrixBytes(context_dmax) +
           MatrixBytes(context_var);
  bytes += VectorBytes(local_dmax) + VectorBytes(local_var) + VectorBytes(quality);
  bytes +=
      VectorBytes(observation_offsets) + VectorBytes(observation_image) + VectorBytes(observations);
  bytes += VectorBytes(neighbour_offsets) + VectorBytes(neighbours);
  bytes += VectorBytes(image_offsets) + VectorBytes(image_landmarks);
  bytes += VectorBytes(lookalike_offsets) + VectorBytes(lookalike_location) +
           VectorBytes(lookalike_ratio);
  bytes += MatrixBytes(local_projected) + VectorBytes(local_projected_sqnorm) +
           VectorBytes(local_residual_norm);
  const PlaceIndex& p = place_index;
  bytes += MatrixBytes(p.vocabulary.centroids) + VectorBytes(p.landmark_word) +
           VectorBytes(p.holistic.codebook) + VectorBytes(p.holistic.codes);
  const InvertedFile& f = inverted_file;
  bytes += VectorBytes(f.offsets) + VectorBytes(f.location) + VectorBytes(f.signature) +
           VectorBytes(f.idf) + VectorBytes(f.location_scale) + VectorBytes(f.thresholds) +
           sizeof(f.projection);
  return bytes + VectorBytes(local_mean_sqnorm);
}

}  // namespace sceneloc
