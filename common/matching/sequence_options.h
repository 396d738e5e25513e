// The settings of the sequence filter (sequence_filter.h), a section of the matching
// settings (MatchOptions::sequence; `sequence:` in configs/match.yaml).
#pragma once

#include "common/util/settings.h"
#include "common/util/status.h"

namespace sceneloc {

struct SequenceOptions {
  // The fastest speed in tour locations per frame up the route (max_forward) and down it
  // (max_backward). -1 = from the map: twice SequenceFilter::MotionBand, the median number
  // of tour frames a landmark is seen in (4 on every development map).
  int max_forward = -1;
  int max_backward = -1;
  // Per frame, the probability that the robot's speed changes by half a location per frame
  // (faster or slower; through 0 it turns round): robots keep their pace and direction.
  double speed_change = 0.02;
  // Per frame, the probability that the speed is drawn afresh, any speed equally likely: a
  // heavy tail on the speed's change, so that a robot changing pace at once is followed
  // while speed_change stays small for the steady robot. 0 = off. 0.02 / 0.01 against 0.05
  // / 0 over the suite's 11 sets x 8 walks: mean ±2 0.932 -> 0.934, correct LOCALISED
  // +1.1% (docs/results.md "Sessions: a speed that may change at once").
  double speed_jump = 0.01;
  // The kidnap floor: per frame, this share of the in-map mass is spread over every
  // location, so a robot carried elsewhere is found again within a few frames.
  double jump = 0.03;
  // Per frame, the probability of leaving the route (in-map -> off-map) and of coming back
  // onto it anywhere (off-map -> in-map).
  double leave = 0.02;
  double enter = 0.2;
  // A frame's fused evidence (LocationScores) is read as a log-likelihood at this
  // temperature: its own setting, not the map's confidence temperature, which is fitted for
  // single frames. What matters is evidence_weight / evidence_temperature (0.45 / 0.28 keeps
  // the 0.5 / 0.31 the filter was measured with).
  double evidence_temperature = 0.28;
  // The exponent on each frame's likelihood (0, 1]: 1 treats frames as independent.
  double evidence_weight = 0.45;
  // A frame's evidence places the robot only to within the tour frames whose views overlap
  // the one it matched: each location's likelihood also counts for the locations within
  // the map's band of it (SequenceFilter::MotionBand), multiplied by this per location of
  // distance (0.5: 1/2 for a neighbour, 1/4 two away). 0 = each location's own evidence
  // only. Measured: docs/results.md "Sessions: evidence spread over overlapping views".
  double evidence_spread = 0.5;
  // The share of each frame's evidence treated as possibly uninformative: a location's
  // likelihood ratio L becomes (1 - evidence_floor) L + evidence_floor P(in the map), so one
  // misleading frame (a look-alike) lowers the right place by a bounded factor. 0 = off.
  // 0.2 on the night from the other side of the path (the suite): ±2 in order 0.60 -> 0.65,
  // its LOCALISED precision 0.72 -> 0.87, the other sets unchanged; but a kidnapped robot is
  // found 2-3 frames later on every set (docs/results.md "Sessions: a floor under the
  // evidence"). Off by default until more hard sequences decide; an operator whose robots
  // meet mostly wrong single frames (night, the other side of the route) should set it.
  double evidence_floor = 0;
  // How far the session believes its own track. The filter's belief is right only while
  // its model is: where frames stop supporting the track it holds (a look-alike stretch
  // locked on, at night from the other side of the route), its motion model keeps the
  // belief where it was and the mass stays high on a wrong answer. So a session also keeps
  // P(the frames support its track), `support`, a two-state chain over "supported" and
  // "not": each frame it switches with probability support_switch, and the frame weighs
  // "supported" by its likelihood ratio (N x its single-frame posterior within a frame's
  // travel of the answer, over the locations there)^support_weight, "not" by 1 (the frame
  // says nothing about the track; the ratio is at least 1/5). The answer's probability is
  // then support x the belief within the tolerance + (1 - support) x the frame's own
  // single-frame probability there, that one at most the belief: the support only ever
  // lowers what the belief says.
  // support_weight 0 = off: the belief alone. Measured:
  // docs/results.md "Sessions: a confidence that checks the track".
  double support_weight = 0.25;
  double support_switch = 0.05;
  // With answer_window, the answer is the location with the most belief within the map's
  // tolerance of it, the decision most probably right when an answer within the tolerance
  // counts as right, rather than the single most probable location (which on a broad
  // belief may sit at one edge of it). Off by default: over the suite's 11 sets x 8 walks
  // mean ±2 0.9344 -> 0.9361, session ECE 0.064 -> 0.059, correct LOCALISED +0.8%, but in
  // route order 0.961 -> 0.957: where the frames' evidence runs ahead of the truth (Gardens
  // Point 12 and 30-31, answered 3 ahead by single frames) it follows the evidence out of the
  // tolerance, surer than before (docs/results.md "Sessions: the answer where the most belief
  // lies").
  bool answer_window = false;
  // A filtered answer whose probability (above) is below this is UNKNOWN.
  double min_confidence = 0.8;
  // Between frames a session keeps every location's belief but the distribution over
  // speeds only of this many locations, the most probable; the others share one. It bounds
  // a session's state to N + 1 + K + (K + 1) S values (sequence_filter.h) instead of S N + 1:
  // 44 KB instead of 680 KB at 10,000 locations. Measured on the dev sets: 16 answers as
  // every location's own (docs/results.md "Sessions: a state that does not grow with the
  // speeds").
  int tracked_locations = 64;

  // The robot's camera is rarely the tour's: another focal length makes everything look
  // larger or smaller by one factor, and verification's scale cue (MatchOptions::
  // verify_scale_sigma), which tells a frame from its neighbours by how large things look,
  // then prefers a frame metres off. A session learns the factor: on each LOCALISED answer
  // whose best verified candidate within the tolerance has at least camera_min_inliers
  // inliers (12: 1.5x the chance level), the inlier-weighted median log size ratio of those
  // candidates (above chance) is one measurement; the median of every measurement so far,
  // once there are camera_min_frames of them, is the camera's (MatchOptions::
  // camera_log_scale) for the session's next frames, the session's answer and each frame's
  // own. Frames outside a session assume the tour's camera unless their request states one.
  // Measured: docs/results.md "Sessions learn the robot's camera".
  bool learn_camera_scale = true;
  int camera_min_inliers = 12;
  int camera_min_frames = 3;
  // The measurements are kept as counts in kCameraBins bins of kCameraBinWidth from
  // -kCameraRange (measurements beyond the range count in the end bins): the median to a
  // fraction of a bin in constant state, 128 bytes.
  static constexpr int kCameraBins = 64;
  static constexpr double kCameraRange = 0.8;
  static constexpr double kCameraBinWidth = 2 * kCameraRange / kCameraBins;

  // The ranges of SequenceSettings.
  Status Validate() const;
};

// The `sequence:` section of the matching settings, bound to `o` (match_settings.cc).
SettingTable SequenceSettings(SequenceOptions* o);

}  // namespace sceneloc
