#include "common/map/train_options.h"

namespace sceneloc {

SettingTable TrainSettings(TrainOptions* o) {
  SettingTable t = ExtractorSettings(&o->extractor, "extractor");
  const SettingTable own = {
      Setting("tracking", "distance_threshold", &o->track_distance_threshold)
          .Range(1e-6, 2)
          .Help("t: largest local descriptor distance for a link (paper: 0.6)"),
      Setting("tracking", "ransac_threshold", &o->ransac_threshold)
          .Range(1e-5, 0.1)
          .Help("epipolar inlier distance, fraction of the frame's long side (2 px at 480)"),
      Setting("tracking", "ransac_confidence", &o->ransac_confidence).Range(0.5, 0.999999),
      Setting("tracking", "min_links_per_pair", &o->min_links_per_pair)
          .Range(8, 100000)
          .Help("fewer links than this between two images are not trusted"),
      Setting("tracking", "min_track_length", &o->min_track_length)
          .Range(1, 1000)
          .Help("images a track must span to become a landmark (1 = every feature)"),
      Setting("tracking", "min_landmarks_per_image", &o->min_landmarks_per_image)
          .Range(0, 100000)
          .Help("top up images with fewer candidates with single-view ones (0 = off)"),
      Setting("landmarks", "local_var_floor", &o->local_var_floor)
          .Range(1e-9, 4)
          .Help("sigma^2_min of the local descriptor (measured: docs/results.md)"),
      Setting("landmarks", "context_var_floor", &o->context_var_floor)
          .Range(1e-9, 4)
          .Help("sigma^2_min of each context histogram"),
      Setting("landmarks", "distance_sd_floor", &o->distance_sd_floor)
          .Range(1e-5, 1)
          .Help("neighbour distance sd floor, fraction of the long side (20 px at 480)"),
      Setting("landmarks", "angle_var_floor", &o->angle_var_floor)
          .Range(1e-9, 40)
          .Unit("radians^2"),
      Setting("landmarks", "max_neighbours", &o->max_neighbours)
          .Range(0, 256)
          .Help("co-occurring neighbours kept per landmark, nearest first"),
      Setting("selection", "quality_s_min", &o->quality_s_min)
          .Range(1e-6, 0.999999)
          .Help("S_min used by the quality Q (eq. 4)"),
      Setting("selection", "quality_fp_prior", &o->quality_fp_prior)
          .Range(0, 1e9)
          .Help("Q = TP / (prior + FP): the zero-denominator rule"),
      Setting("selection", "eta", &o->eta)
          .Range(0, 1000000)
          .Help("landmarks per tour image (0 = keep all with Q > q_min); measured"),
      Setting("selection", "q_min", &o->q_min).Range(0, 1e9).Help("paper: 0.01"),
      Setting("selection", "quality_window", &o->quality_window)
          .Range(0, 1000000)
          .Unit("images")
          .Help("Q measured over chunks of this many tour images (0 = the whole tour, paper)"),
      Setting("place_index", "min_locations", &o->place_index_min_locations)
          .Range(0, 100000000)
          .Unit("locations")
          .Help("maps this large get a coarse stage that picks the locations a query is scored "
                "against (0 = never: every query scores every landmark)"),
      Setting("calibration", "tolerance", &o->tolerance)
          .Range(0, 100)
          .Unit("frames")
          .Help("confidence = P(answer within this many frames of the truth)"),
      Setting("calibration", "confidence_temperature", &o->confidence_temperature)
          .Range(1e-3, 100)
          .Help("the posterior's temperature (common/matching/confidence.h); measured"),
      Setting("calibration", "map_evidence_slope", &o->map_evidence_slope)
          .Range(1e-3, 100)
          .Help("P(on the route) logistic's slope; measured"),
      Setting("calibration", "map_evidence_offset", &o->map_evidence_offset)
          .Range(-100, 100)
          .Help("and its offset; measured"),
  };
  t.insert(t.end(), own.begin(), own.end());
  return t;
}

Status TrainOptions::Validate() const {
  TrainOptions copy = *this;
  SCENELOC_RETURN_IF_ERROR(CheckSettings(TrainSettings(&copy)));
  return extractor.holistic.Validate();
}

}  // namespace sceneloc
