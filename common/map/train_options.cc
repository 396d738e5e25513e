#include "common/map/train_options.h"

#include <cmath>
#include <sstream>
#include <string>

namespace sceneloc {
namespace {

std::string Format(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// Checks lo < value <= hi (or lo < value < hi when hi_open). NaN and infinities fail.
Status CheckOpenRange(const char* name, double value, double lo, double hi, bool hi_open) {
  const bool ok = std::isfinite(value) && value > lo && (hi_open ? value < hi : value <= hi);
  if (ok) return Status::Ok();
  return InvalidArgument(std::string(name) + " must be in (" + Format(lo) + ", " + Format(hi) +
                         (hi_open ? ")" : "]") + ", got " + Format(value));
}

// Checks value > 0 (finite).
Status CheckPositive(const char* name, double value) {
  if (std::isfinite(value) && value > 0.0) return Status::Ok();
  return InvalidArgument(std::string(name) + " must be > 0, got " + Format(value));
}

// Checks value >= min (finite).
Status CheckAtLeast(const char* name, double value, double min) {
  if (std::isfinite(value) && value >= min) return Status::Ok();
  return InvalidArgument(std::string(name) + " must be >= " + Format(min) + ", got " +
                         Format(value));
}

// The extractor names its fields bare ("working_size"); here they are one level down.
Status ValidateExtractor(const ExtractorOptions& extractor) {
  Status status = extractor.Validate();
  if (status.ok()) return status;
  return Status(status.code(), "extractor." + status.message());
}

}  // namespace

Status TrainOptions::Validate() const {
  SCENELOC_RETURN_IF_ERROR(ValidateExtractor(extractor));
  SCENELOC_RETURN_IF_ERROR(
      CheckOpenRange("track_distance_threshold", track_distance_threshold, 0.0, 2.0, false));
  SCENELOC_RETURN_IF_ERROR(CheckOpenRange("ransac_threshold", ransac_threshold, 0.0, 0.1, false));
  SCENELOC_RETURN_IF_ERROR(
      CheckOpenRange("ransac_confidence", ransac_confidence, 0.0, 1.0, /*hi_open=*/true));
  SCENELOC_RETURN_IF_ERROR(CheckAtLeast("min_links_per_pair", min_links_per_pair, 8));
  SCENELOC_RETURN_IF_ERROR(CheckAtLeast("min_track_length", min_track_length, 1));
  SCENELOC_RETURN_IF_ERROR(CheckAtLeast("min_landmarks_per_image", min_landmarks_per_image, 0));
  SCENELOC_RETURN_IF_ERROR(CheckPositive("local_var_floor", local_var_floor));
  SCENELOC_RETURN_IF_ERROR(CheckPositive("context_var_floor", context_var_floor));
  SCENELOC_RETURN_IF_ERROR(CheckOpenRange("distance_sd_floor", distance_sd_floor, 0.0, 1.0, false));
  SCENELOC_RETURN_IF_ERROR(CheckPositive("angle_var_floor", angle_var_floor));
  SCENELOC_RETURN_IF_ERROR(
      CheckOpenRange("quality_s_min", quality_s_min, 0.0, 1.0, /*hi_open=*/true));
  SCENELOC_RETURN_IF_ERROR(CheckAtLeast("quality_fp_prior", quality_fp_prior, 0.0));
  SCENELOC_RETURN_IF_ERROR(CheckAtLeast("eta", eta, 0));
  SCENELOC_RETURN_IF_ERROR(CheckAtLeast("q_min", q_min, 0.0));
  if (tolerance < 0 || tolerance > 100) {
    return InvalidArgument("tolerance must be in [0, 100], got " + std::to_string(tolerance));
  }
  SCENELOC_RETURN_IF_ERROR(
      CheckOpenRange("confidence_temperature", confidence_temperature, 0.0, 100.0, false));
  SCENELOC_RETURN_IF_ERROR(
      CheckOpenRange("map_evidence_slope", map_evidence_slope, 0.0, 100.0, false));
  if (!(std::isfinite(map_evidence_offset) && std::abs(map_evidence_offset) <= 100)) {
    return InvalidArgument("map_evidence_offset must be in [-100, 100]");
  }
  if (max_neighbours < 0 || max_neighbours > 256) {
    return InvalidArgument("max_neighbours must be in [0, 256], got " +
                           std::to_string(max_neighbours));
  }
  return Status::Ok();
}

}  // namespace sceneloc
