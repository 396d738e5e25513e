// The matching settings, declared once (common/util/settings.h): configs/match.yaml, the
// server's matching: and sequence: sections and their flags, and Validate().
#include <string>

#include "common/matching/localiser.h"
#include "common/matching/sequence_options.h"

namespace sceneloc {

SettingTable MatchSettings(MatchOptions* o) {
  SettingTable t = {
      Setting("matching", "s_min", &o->s_min)
          .Range(1e-6, 1)
          .Help("drop feature-landmark pairs with S_D below this (paper: 0.3)"),
      Setting("matching", "use_neighbourhood", &o->use_neighbourhood)
          .Help("S = S_D * S_N (paper); false = S_D alone"),
      Setting("matching", "include_centre_term", &o->include_centre_term)
          .Help("eq. 2 denominator from n = 0, as printed"),
      Setting("matching", "max_neighbours", &o->max_neighbours)
          .Range(0, 256)
          .Help("neighbours walked per landmark (0 = all stored)"),
      Setting("matching", "max_matches_per_landmark", &o->max_matches_per_landmark)
          .Range(0, 100000)
          .Help("best query features kept per landmark (0 = all): a work budget"),
      Setting("matching", "distinctiveness", &o->distinctiveness)
          .Help("weight pairs by p(g|f) (eq. 4's posterior); off = eq. 3"),
      Setting("matching", "size_exponent", &o->size_exponent)
          .Range(0, 2)
          .Help("L(l) divides by |G_l|^size_exponent (1 = eq. 3)"),
      Setting("matching", "verify_top", &o->verify_top)
          .Range(0, 1000)
          .Help("verify the best by L (0 and use_holistic false = paper: by L only)"),
      Setting("matching", "use_holistic", &o->use_holistic)
          .Help("holistic evidence: candidates and fusion (false = local features only)"),
      Setting("matching", "holistic_top", &o->holistic_top)
          .Range(0, 1000)
          .Help("also verify the tour images most alike as a whole (0 = none)"),
      Setting("matching", "verify_ransac_threshold", &o->verify_ransac_threshold)
          .Range(1e-5, 0.1)
          .Help("RANSAC inlier distance, fraction of the long side (3 px at 480)"),
      Setting("matching", "verify_ransac_iterations", &o->verify_ransac_iterations)
          .Range(1, 100000),
      Setting("matching", "verify_estimator", &o->verify_estimator)
          .Choices({"usac", "ransac"})
          .Help("usac: RANSAC with SPRT (fast); ransac: OpenCV's classic FM_RANSAC"),
      Setting("matching", "verify_angle_tolerance", &o->verify_angle_tolerance)
          .Range(0, 180)
          .Unit("degrees")
          .Help("drop correspondences whose orientations differ more (0 = off)"),
      Setting("matching", "verify_scale_sigma", &o->verify_scale_sigma)
          .Range(0, 10)
          .Help("weight inliers by keypoint-scale agreement (0 = off)"),
      Setting("matching", "verify_chance_inliers", &o->verify_chance_inliers)
          .Range(0, 1000)
          .Help("weighted inliers a wrong candidate reaches by chance: only more count"),
      Setting("matching", "verify_weight", &o->verify_weight)
          .Range(0, 100)
          .Help("holistic z-score units per inlier above that"),
      Setting("matching", "confidence_model", &o->confidence_model)
          .Choices({"calibrated", "paper"})
          .Help("P(answer within the map's tolerance); paper = L1/(L1+L2)"),
      Setting("matching", "confidence_plateau", &o->confidence_plateau)
          .Range(1, 10)
          .Help("the answer's +-(tolerance + 1) frames at this x the temperature; 1 = off"),
      Setting("matching", "confidence_scale_spread", &o->confidence_scale_spread)
          .Range(0, 1)
          .Help("average the confidence over cameras this far (log scale, 1 sd); 0 = off"),
      Setting("matching", "min_confidence", &o->min_confidence)
          .Range(0, 1)
          .Help("answers below are UNKNOWN (measured: docs/results.md)"),
      Setting("matching", "top_k", &o->top_k).Range(1, 1000).Help("ranked locations per answer"),
      Setting("matching", "use_place_index", &o->use_place_index)
          .Help("on maps with a place index, score only the locations it picks (false = all)"),
      Setting("matching", "place_word_top", &o->place_word_top)
          .Range(0, 100000)
          .Help("locations picked by shared visual words"),
      Setting("matching", "place_hamming_max", &o->place_hamming_max)
          .Range(0, 64)
          .Unit("bits")
          .Help(
              "a shared word counts if the signatures differ in at most this many of 64 (0 = any)"),
      Setting("matching", "place_holistic_top", &o->place_holistic_top)
          .Range(0, 100000)
          .Help("locations picked by approximate holistic distance"),
      Setting("matching", "place_expand", &o->place_expand)
          .Range(0, 1000)
          .Unit("locations")
          .Help("each picked location brings this many either side"),
      Setting("matching", "place_distinct", &o->place_distinct)
          .Help("pass over picks already among the candidates for the next best"),
  };
  for (SettingField& f : SequenceSettings(&o->sequence)) t.push_back(std::move(f));
  return t;
}

SettingTable SequenceSettings(SequenceOptions* o) {
  return {
      Setting("sequence", "max_forward", &o->max_forward)
          .Range(0, 32)
          .Off(-1)
          .Help("fastest speed up the route, locations per frame (-1 = from the map)")
          .Flag("sequence-max-forward"),
      Setting("sequence", "max_backward", &o->max_backward)
          .Range(0, 32)
          .Off(-1)
          .Help("and down it (-1 = from the map)")
          .Flag("sequence-max-backward"),
      Setting("sequence", "speed_change", &o->speed_change)
          .Range(0, 1)
          .Help("per frame, P(the speed changes by half a location per frame)")
          .Flag("sequence-speed-change"),
      Setting("sequence", "speed_jump", &o->speed_jump)
          .Range(0, 1)
          .Help("per frame, P(the speed is drawn afresh, any speed equally likely)")
          .Flag("sequence-speed-jump"),
      Setting("sequence", "jump", &o->jump)
          .Range(0, 1)
          .Help("kidnap floor: share of the belief spread over every location per frame")
          .Flag("sequence-jump"),
      Setting("sequence", "leave", &o->leave)
          .Range(0, 1)
          .Help("per frame, P(leaving the route)")
          .Flag("sequence-leave"),
      Setting("sequence", "enter", &o->enter)
          .Range(0, 1)
          .Help("per frame, P(coming back onto it, anywhere)")
          .Flag("sequence-enter"),
      Setting("sequence", "evidence_temperature", &o->evidence_temperature)
          .Range(1e-3, 100)
          .Help("a frame's fused evidence is its log-likelihood at this temperature")
          .Flag("sequence-evidence-temperature"),
      Setting("sequence", "evidence_weight", &o->evidence_weight)
          .Range(1e-6, 1)
          .Help("exponent on each frame's likelihood (1 = frames independent)")
          .Flag("sequence-evidence-weight"),
      Setting("sequence", "evidence_spread", &o->evidence_spread)
          .Range(0, 1)
          .Help("a location's evidence also counts x this per location for its band (0 = off)")
          .Flag("sequence-evidence-spread"),
      Setting("sequence", "evidence_floor", &o->evidence_floor)
          .Range(0, 0.99)
          .Help("share of a frame's evidence treated as possibly uninformative (0 = off)")
          .Flag("sequence-evidence-floor"),
      Setting("sequence", "support_weight", &o->support_weight)
          .Range(0, 10)
          .Help("exponent on a frame's support of the session's track (0 = off: belief alone)")
          .Flag("sequence-support-weight"),
      Setting("sequence", "support_switch", &o->support_switch)
          .Range(0, 0.5)
          .Help("per frame, P(the track's support changes)")
          .Flag("sequence-support-switch"),
      Setting("sequence", "answer_window", &o->answer_window)
          .Help("answer where the most belief lies within the tolerance (false: the mode)")
          .Flag("sequence-answer-window"),
      Setting("sequence", "min_confidence", &o->min_confidence)
          .Range(0, 1)
          .Help("session answers below this are UNKNOWN")
          .Flag("sequence-min-confidence"),
      Setting("sequence", "tracked_locations", &o->tracked_locations)
          .Range(0, 1000000)
          .Help("locations whose speeds a session keeps; the rest share one distribution")
          .Flag("sequence-tracked-locations"),
      Setting("sequence", "learn_camera_scale", &o->learn_camera_scale)
          .Help("learn how much larger the robot's camera sees things than the tour's")
          .Flag("sequence-learn-camera-scale"),
      Setting("sequence", "camera_min_inliers", &o->camera_min_inliers)
          .Range(1, 100000)
          .Help("inliers a LOCALISED answer's match needs to measure the camera's scale")
          .Flag("sequence-camera-min-inliers"),
      Setting("sequence", "camera_min_frames", &o->camera_min_frames)
          .Range(1, 1000000)
          .Help("measurements before the session uses its camera's scale")
          .Flag("sequence-camera-min-frames"),
  };
}

Status MatchOptions::Validate() const {
  MatchOptions copy = *this;
  return CheckSettings(MatchSettings(&copy));
}

Status SequenceOptions::Validate() const {
  SequenceOptions copy = *this;
  return CheckSettings(SequenceSettings(&copy));
}

}  // namespace sceneloc
