#include "common/config/config.h"

namespace sceneloc {

SettingTable TrainSettingTable(TrainOptions* o) {
  ExtractorOptions* e = &o->extractor;
  return {
      {"extractor", "max_features", &e->max_features, 0, 100000},
      {"extractor", "working_size", &e->working_size, 64, 4096},
      {"extractor", "context_scale", &e->context_scale, 1.01, 8},
      {"extractor", "contrast_threshold", &e->contrast_threshold, 1e-6, 1},
      {"extractor", "edge_threshold", &e->edge_threshold, 1e-6, 1000},
      {"extractor", "sigma", &e->sigma, 0.1, 10},
      {"extractor", "max_image_side", &e->max_image_side, 16, 65536},
      {"extractor", "clahe_clip", &e->clahe_clip, 0, 100},
      {"extractor", "root_sift", &e->root_sift, 0, 1},
      {"extractor", "holistic_cols", &e->holistic.cols, 0, 64},
      {"extractor", "holistic_cell_pixels", &e->holistic.cell_pixels, 2, 64},
      {"extractor", "holistic_bins", &e->holistic.bins, 4, 36},
      {"extractor", "holistic_max_shift", &e->holistic.max_shift, 0, 63},
      {"tracking", "distance_threshold", &o->track_distance_threshold, 1e-6, 2},
      {"tracking", "ransac_threshold", &o->ransac_threshold, 1e-5, 0.1},
      {"tracking", "ransac_confidence", &o->ransac_confidence, 0.5, 0.999999},
      {"tracking", "min_links_per_pair", &o->min_links_per_pair, 8, 100000},
      {"tracking", "min_track_length", &o->min_track_length, 1, 1000},
      {"tracking", "min_landmarks_per_image", &o->min_landmarks_per_image, 0, 100000},
      {"landmarks", "local_var_floor", &o->local_var_floor, 1e-9, 4},
      {"landmarks", "context_var_floor", &o->context_var_floor, 1e-9, 4},
      {"landmarks", "distance_sd_floor", &o->distance_sd_floor, 1e-5, 1},
      {"landmarks", "angle_var_floor", &o->angle_var_floor, 1e-9, 40},
      {"landmarks", "max_neighbours", &o->max_neighbours, 0, 256},
      {"selection", "quality_s_min", &o->quality_s_min, 1e-6, 1},
      {"selection", "quality_fp_prior", &o->quality_fp_prior, 0, 1e9},
      {"selection", "eta", &o->eta, 0, 1000000},
      {"selection", "q_min", &o->q_min, 0, 1e9},
      {"calibration", "tolerance", &o->tolerance, 0, 100},
      {"calibration", "confidence_temperature", &o->confidence_temperature, 1e-3, 100},
      {"calibration", "map_evidence_slope", &o->map_evidence_slope, 1e-3, 100},
      {"calibration", "map_evidence_offset", &o->map_evidence_offset, -100, 100},
  };
}

SettingTable MatchSettingTable(MatchOptions* o) {
  return {
      {"matching", "s_min", &o->s_min, 1e-6, 1},
      {"matching", "use_neighbourhood", &o->use_neighbourhood, 0, 1},
      {"matching", "include_centre_term", &o->include_centre_term, 0, 1},
      {"matching", "max_neighbours", &o->max_neighbours, 0, 256},
      {"matching", "max_matches_per_landmark", &o->max_matches_per_landmark, 0, 100000},
      {"matching", "distinctiveness", &o->distinctiveness, 0, 1},
      {"matching", "size_exponent", &o->size_exponent, 0, 2},
      {"matching", "verify_top", &o->verify_top, 0, 1000},
      {"matching", "use_holistic", &o->use_holistic, 0, 1},
      {"matching", "holistic_top", &o->holistic_top, 0, 1000},
      {"matching", "verify_ransac_threshold", &o->verify_ransac_threshold, 1e-5, 0.1},
      {"matching", "verify_ransac_iterations", &o->verify_ransac_iterations, 1, 100000},
      {"matching", "verify_angle_tolerance", &o->verify_angle_tolerance, 0, 180},
      {"matching", "verify_scale_sigma", &o->verify_scale_sigma, 0, 10},
      {"matching", "verify_chance_inliers", &o->verify_chance_inliers, 0, 1000},
      {"matching", "verify_weight", &o->verify_weight, 0, 100},
      {"matching", "confidence_model", &o->confidence_model, 0, 0},
      {"matching", "min_confidence", &o->min_confidence, 0, 1},
      {"matching", "top_k", &o->top_k, 1, 1000},
      {"sequence", "max_forward", &o->sequence.max_forward, -1, 1000, "", "sequence-max-forward"},
      {"sequence", "max_backward", &o->sequence.max_backward, -1, 1000, "",
       "sequence-max-backward"},
      {"sequence", "backward_weight", &o->sequence.backward_weight, 0, 1, "",
       "sequence-backward-weight"},
      {"sequence", "jump", &o->sequence.jump, 0, 1, "", "sequence-jump"},
      {"sequence", "leave", &o->sequence.leave, 0, 1, "", "sequence-leave"},
      {"sequence", "enter", &o->sequence.enter, 0, 1, "", "sequence-enter"},
      {"sequence", "evidence_weight", &o->sequence.evidence_weight, 1e-6, 1, "",
       "sequence-evidence-weight"},
      {"sequence", "min_confidence", &o->sequence.min_confidence, 0, 1, "",
       "sequence-min-confidence"},
  };
}

Status ParseTrainOptions(const std::string& yaml, const std::string& name, TrainOptions* options) {
  TrainOptions updated = *options;
  SCENELOC_RETURN_IF_ERROR(ApplySettings(yaml, name, TrainSettingTable(&updated)));
  const Status valid = updated.Validate();
  if (!valid.ok()) return InvalidArgument(name + ": " + valid.message());
  *options = updated;
  return Status::Ok();
}

Status ParseMatchOptions(const std::string& yaml, const std::string& name, MatchOptions* options) {
  MatchOptions updated = *options;
  SCENELOC_RETURN_IF_ERROR(ApplySettings(yaml, name, MatchSettingTable(&updated)));
  const Status valid = updated.Validate();
  if (!valid.ok()) return InvalidArgument(name + ": " + valid.message());
  *options = updated;
  return Status::Ok();
}

Status LoadTrainOptions(const std::string& path, TrainOptions* options) {
  SCENELOC_ASSIGN_OR_RETURN(const std::string text, ReadSettingsFile(path));
  return ParseTrainOptions(text, path, options);
}

Status LoadMatchOptions(const std::string& path, MatchOptions* options) {
  SCENELOC_ASSIGN_OR_RETURN(const std::string text, ReadSettingsFile(path));
  return ParseMatchOptions(text, path, options);
}

std::string TrainOptionsToYaml(const TrainOptions& options) {
  TrainOptions copy = options;
  return SettingsToYaml(TrainSettingTable(&copy));
}

std::string MatchOptionsToYaml(const MatchOptions& options) {
  MatchOptions copy = options;
  return SettingsToYaml(MatchSettingTable(&copy));
}

}  // namespace sceneloc
