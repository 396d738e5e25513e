// A Bayes filter over a robot's frames (our addition to the paper, after the sequence
// methods of place recognition: SeqSLAM, RTAB-Map's hypotheses, FAB-MAP's motion model).
// Each frame is localised on its own (localiser.h); the filter combines that single-frame
// evidence with where the robot was a moment ago.
//
// The state is a belief over (tour location, speed along the route) for the map's N tour
// locations and the speeds -max_backward..max_forward locations per frame in steps of half
// a location (negative: down the route, towards lower location numbers), plus one "off the
// map" state.
// One step, causal (an answer uses only the frames so far):
//   predict:  the speed changes by half a location per frame with probability
//             speed_change (otherwise it is kept), and with probability speed_jump it is
//             drawn afresh (any speed; a robot that changes pace at once is followed while
//             the steady robot's speed stays stiff), then the robot steps its speed (a half
//             speed split between the whole steps around it), give or take one location
//             (1/6, 4/6, 1/6); a step past an end of the route turns round there
//             and walks back the rest at the opposite speed. A kidnap floor spreads `jump`
//             of the mass over every location and speed, so a robot carried elsewhere is
//             found again; off-map enters and leaves at the rates below.
//   update:   belief'(l, v) *= P(frame | l)^evidence_weight, normalised. P(frame | l) is
//             the calibrated confidence's reading of the evidence (confidence.h): the fused
//             scores as a posterior exp(s_l / T) over locations times P(in the map), over
//             a uniform prior, i.e. a likelihood ratio, spread over the locations within
//             the map's band (x evidence_spread per location of distance): a frame that
//             matches one tour view matches the views that overlap it, so it places the
//             robot to within a few frames, and the speed keeps the pace between.
//             evidence_weight < 1 tempers it: consecutive frames are not independent (the
//             same look-alike fools both). With evidence_floor f > 0 the likelihood ratio
//             is (1 - f) L + f P(in map): a frame may be uninformative (off by default).
//   answer:   the location with the most belief over every speed (with
//             SequenceOptions::answer_window, the most within the tolerance of it); its
//             probability is that belief as far as the frames support the track the belief
//             follows (SequenceOptions::support_weight: a two-state chain, "supported" or
//             not, weighed each frame by its own posterior near the answer), else the
//             frame's own single-frame probability there.
//   camera:   a LOCALISED answer measures how much larger the robot's camera sees things
//             than the tour's (SequenceOptions::learn_camera_scale); once learnt, the
//             session reads its frames' verified candidates with it (MeasureCamera,
//             CameraLogScale).
// The speed is state because robots keep their pace and their direction, and the pace is
// not the tour's: a robot sending frames faster than the tour was recorded moves a fraction
// of a location per frame, one driving faster several. The models before it (a band of
// steps 0..2 each equally likely, with the direction of travel as state) assumed a pace
// near one location per frame and lost robots at two or three (docs/results.md "Sessions:
// the robot's speed as state").
// Between frames a session keeps the belief of every location but the speeds of only the
// most probable K (tracked_locations, 64): a location's belief is the product of where
// the robot is and how fast it goes, and away from the few places it might be, the speeds
// hardly differ (measured lossless from K = 16 on the dev sets).
// A step never forms the full belief over (location, speed): the untracked locations share
// one distribution over speeds, so their move is a correlation of their belief with one
// kernel over the steps' span; only the tracked locations and those within a step of an
// end (where steps turn round) move speed by speed. The same answers as the full belief's
// (tests/matching/sequence_filter_test.cc, SparseStepsAreTheDenseModels).
// Cost: O(N W + K S) per frame, W = max_forward + max_backward + 3 the steps' span;
// N + 1 + K + (K + 1) S values per session, S = 2 (max_forward + max_backward) + 1 speeds
// (17 with the map's default band of 2). 0.9 ms a frame at 20,000 locations and 25 speeds
// on the 2-core VM (bench/sequence_filter_benchmark.cc; 5.4 ms with the full belief).
//
// Thread-compatible: a SequenceState belongs to one session; the functions are pure.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "common/map/map.h"
#include "common/matching/localiser.h"
#include "common/matching/sequence_options.h"
#include "common/util/status.h"

namespace sceneloc {

// One frame's evidence, as the localiser gives it.
struct FrameEvidence {
  // Every location's fused evidence (LocaliseResult::location_scores); empty = none (a
  // frame without features): the step only predicts.
  std::vector<float> location_scores;
  // P(the frame shows a place of the route), or -1 when unknown.
  double in_map = -1;
  // The verified candidates and the settings their scores were fused with: a session that
  // has learnt its camera's scale reads them again with it (SequenceOptions::
  // learn_camera_scale), and measures the scale on them. Empty: nothing to re-read. Their
  // camera_log_scale is the one the frame was read with (LocaliseResult's).
  std::vector<CandidateEvidence> candidates;
  MatchOptions fusion;
  // The robot camera's log scale as its client states it (LocaliseRequest.camera_scale):
  // the frame is read with it rather than with what the session has learnt (which the
  // session goes on measuring). Unset: the session's own.
  std::optional<double> camera_log_scale;
};

// The evidence of a localise result against `map` (its calibration's P(in the map)),
// localised with `options`.
FrameEvidence EvidenceOf(const LocaliseResult& result, const Map& map, const MatchOptions& options);

// A session's belief between frames, compact: belief(l, v) = location[l] P(v | l), with
// P(v | l) kept for the `tracked` locations and one distribution shared by the others
// (SequenceOptions::tracked_locations). Empty (no frames yet) until the first Update.
struct SequenceState {
  // The N locations' belief over every speed, then off-map; sums to 1.
  std::vector<float> location;
  // The locations whose speed distribution is kept, ascending: the most probable.
  std::vector<uint32_t> tracked;
  // P(speed | location), S values each (slowest, -max_backward, first), summing to 1: one
  // row per tracked location in that order, then the row the others share.
  std::vector<float> speeds;
  uint32_t frames = 0;  // frames filtered so far
  // P(the frames support the session's track) (SequenceOptions::support_weight), in [0, 1];
  // kFreshSupport before the first frame.
  float support = kFreshSupport;
  static constexpr float kFreshSupport = 0.5f;
  // The robot camera's log scale against the tour's as measured on the session's LOCALISED
  // answers: how many measurements fell in each of SequenceOptions::kCameraBins bins
  // (empty before the first).
  std::vector<uint16_t> camera_counts;

  // The heap the state holds, bytes.
  size_t MemoryBytes() const {
    return (location.capacity() + speeds.capacity()) * sizeof(float) +
           tracked.capacity() * sizeof(uint32_t) + camera_counts.capacity() * sizeof(uint16_t);
  }
};

struct SequenceAnswer {
  int location = -1;  // the most probable location (SequenceOptions::answer_window)
  // P(within the map's tolerance of it): the belief there (off-map included in the total),
  // as far as the frames support the track, else the frame's own single-frame probability
  // (SequenceOptions::support_weight).
  double probability = 0;
  double belief = 0;    // the belief within the tolerance alone
  double support = 0;   // SequenceState::support after this frame
  double off_map = 0;   // belief in "off the map"
  uint32_t frames = 0;  // frames the session has seen, this one included
  Decision decision = Decision::kUnknown;
  // The camera's log scale the session read this frame with: the stated one, else the
  // learnt one (until it has learnt one, the one the frame was localised with: FrameCamera,
  // 0 for a frame of the tour frame's shape).
  double camera_log_scale = 0;
  // What the session has learnt of its camera after this frame (CameraLogScale), stated
  // camera or not; until it has learnt one, the frame's camera as above (0 when stated).
  double measured_camera_log_scale = 0;
};

class SequenceFilter {
 public:
  // REQUIRES: options.Validate().ok(); map Finalize()d with at least one location.
  SequenceFilter(const Map& map, const SequenceOptions& options);

  // Adds one frame to `state` (a fresh state starts from a uniform belief) and answers.
  // A state that does not Fit (another map, other settings) is restarted, never read.
  // Any number of threads may update their own states at once; each thread keeps the
  // working memory of its largest update (about ten N-sized arrays of doubles: 0.8 MB at
  // 10,000 locations) for the next.
  SequenceAnswer Update(const FrameEvidence& evidence, SequenceState* state) const;

  // The camera's log scale a session with `state` reads its next frame with: the median of
  // its measurements once there are camera_min_frames of them, else `unlearnt` (the camera
  // the frame was localised with; 0 = the tour's); always `unlearnt` when
  // learn_camera_scale is off.
  double CameraLogScale(const SequenceState& state, double unlearnt = 0) const;

  // Whether `state` is a state of this filter: its sizes, tracked locations ascending on
  // the map, and a support in [0, 1]. Belief values are not checked. A state that tracks
  // more or fewer locations than this filter keeps fits (a server whose tracked_locations
  // differs, in a fleet being reconfigured): the next Update compacts it to num_tracked().
  bool Fits(const SequenceState& state) const;

  // How many tour frames apart the map's views still overlap: the median number of tour
  // images its landmarks are seen in (at least 2). The evidence is spread over it, and the
  // fastest speed either way defaults to twice it.
  static int MotionBand(const Map& map);

  // Where a step to `target` lands on a route of `n` locations: past either end, the robot
  // turns round there and walks the rest of the step back (*turned set). A uniform belief
  // stays uniform through the prediction. REQUIRES: n >= 1.
  static int ReflectAtEnds(int target, int n, bool* turned);

  // The values of a session's state (SequenceState) over `num_locations` tour locations,
  // `speeds` speeds and `tracked` tracked locations.
  static uint64_t StateValues(uint64_t num_locations, uint64_t speeds, uint64_t tracked) {
    return num_locations + 1 + tracked + (tracked + 1) * speeds;
  }
  // Speeds run from -max_backward to max_forward in steps of half a location per frame.
  static constexpr int kSpeedsPerLocation = 2;
  int num_speeds() const { return kSpeedsPerLocation * (forward_ + backward_) + 1; }
  // Locations whose speeds a state keeps: tracked_locations, at most every location.
  int num_tracked() const { return tracked_; }

  int max_forward() const { return forward_; }
  int max_backward() const { return backward_; }

 private:
  // One frame's prediction from a state that Fits, kept sparse (the thread's workspace):
  // the locations whose speeds the state keeps, and those within a step of either end of
  // the route (where steps turn round), move one by one; the others share one speed
  // distribution, so their move is one correlation of their belief with a kernel of the
  // shared speeds' steps (O(N x the steps' span)). What the state cannot keep (the full
  // belief over location and speed) is never formed.
  void Predict(const SequenceState& state) const;
  // The same for a fresh session: every location and speed equally likely.
  void PredictFresh() const;
  // The predicted belief weighed by a frame's evidence (every location's fused score, and
  // P(in the map), -1 unknown), normalised, into `state`: its locations' belief, the
  // num_tracked() most probable locations (ties: the lower location) with their speeds,
  // and the others' shared speeds. Leaves the frame's posterior in the thread's workspace
  // for CheckTrack.
  void Observe(const std::vector<float>& scores, double in_map, SequenceState* state) const;
  // Per location, the weight of the frame's evidence (the thread's workspace), off-map last.
  void EvidenceWeights(const std::vector<float>& scores, double in_map) const;
  // The frame's scores with each location's blended with its look-alikes' (Map::lookalike_*):
  // l's score moves towards each look-alike b's by rho_lb / (1 + l's look-alikes), rho at
  // most kMaxLookAlikeRatio, so that of a pair (or of twins that all know each other) only
  // (1 - rho) of the difference stays, as the single frame's confidence reads an answer's
  // look-alikes (LookAlikeTemperatures), and scores elsewhere keep their mean. Chance
  // differences between twins, frame after frame, then do not lock a session on to the
  // wrong one. `scores` itself for a map without look-alikes.
  const std::vector<float>& BlendLookAlikes(const std::vector<float>& scores) const;
  // A location's speeds after the speed changes (SequenceOptions::speed_change, speed_jump),
  // from its speeds `row` (num_speeds() values).
  void ChangeSpeed(const float* row, double* out) const;
  // Weighs the session's support (SequenceState::support) by how far the frame's posterior
  // (as the Observe just before read it) places the robot within a frame's travel of
  // `answer`, and sets answer->probability and decision.
  void CheckTrack(double in_map, SequenceAnswer* answer, SequenceState* state) const;
  // Adds the camera's scale measured on this frame's answer, if it gives one, to `state`.
  void MeasureCamera(const FrameEvidence& evidence, const SequenceAnswer& answer,
                     SequenceState* state) const;
  // Adds to each location's likelihood its neighbours' within the band, weighted by
  // spread_ (log_lik holds N locations, then off-map, which is left alone). `posterior`:
  // exp(log_lik - its largest) over the N locations.
  void Spread(const std::vector<double>& posterior, std::vector<double>* log_lik) const;
  SequenceAnswer Answer(const SequenceState& state) const;

  // Constant after construction.
  const int num_locations_;
  const int tolerance_;
  const double temperature_;
  const SequenceOptions options_;
  int forward_ = 0;
  int backward_ = 0;
  int tracked_ = 0;
  // evidence_spread^d for d = 0..the map's band; empty when evidence_spread is 0.
  std::vector<double> spread_;
  // The map's look-alikes (Map::lookalike_*; empty without them).
  std::vector<uint32_t> lookalike_offsets_;
  std::vector<uint32_t> lookalike_location_;
  std::vector<float> lookalike_ratio_;
  // Per speed, where one frame takes the robot: whole locations and their weights (sum 1).
  struct Step {
    int locations;
    float weight;
  };
  std::vector<std::vector<Step>> steps_;
  // The least and greatest whole step of any speed, and the locations within a step of
  // either end: min_step_ <= Step::locations <= max_step_, reach_ = max(|min|, |max|).
  int min_step_ = 0;
  int max_step_ = 0;
  int reach_ = 0;
};

}  // namespace sceneloc
