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
//             speed_change (otherwise it is kept), then the robot steps its speed (a half
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
//             same look-alike fools both).
//   answer:   the location with the most belief over every speed.
// The speed is state because robots keep their pace and their direction, and the pace is
// not the tour's: a robot sending frames faster than the tour was recorded moves a fraction
// of a location per frame, one driving faster several. The models before it (a band of
// steps 0..2 each equally likely, with the direction of travel as state) assumed a pace
// near one location per frame and lost robots at two or three (docs/results.md "Sessions:
// the robot's speed as state").
// Cost: O(S N) per frame and S N + 1 floats per session, S = 2 (max_forward + max_backward)
// + 1 speeds (17 with the map's default band of 2).
//
// Thread-compatible: a SequenceState belongs to one session; the functions are pure.
#pragma once

#include <cstdint>
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
};

// The evidence of a localise result against `map` (its calibration's P(in the map)).
FrameEvidence EvidenceOf(const LocaliseResult& result, const Map& map);

// A session's belief. Empty (no frames yet) until the first Update.
struct SequenceState {
  // N locations at the slowest speed (-max_backward), then N at each speed half a location
  // per frame faster up to max_forward, then off-map; sums to 1. SequenceFilter::state_size()
  // values.
  std::vector<float> belief;
  uint32_t frames = 0;  // frames filtered so far
};

struct SequenceAnswer {
  int location = -1;       // the most probable tour location
  double probability = 0;  // belief within the map's tolerance of it (off-map included in
                           // the total)
  double off_map = 0;      // belief in "off the map"
  uint32_t frames = 0;     // frames the session has seen, this one included
  Decision decision = Decision::kUnknown;
};

class SequenceFilter {
 public:
  // REQUIRES: options.Validate().ok(); map Finalize()d with at least one location.
  SequenceFilter(const Map& map, const SequenceOptions& options);

  // Adds one frame to `state` (a fresh state starts from a uniform belief) and answers.
  // A state of the wrong size (another map) is restarted, never read.
  SequenceAnswer Update(const FrameEvidence& evidence, SequenceState* state) const;

  // How many tour frames apart the map's views still overlap: the median number of tour
  // images its landmarks are seen in (at least 2). The evidence is spread over it, and the
  // fastest speed either way defaults to twice it.
  static int MotionBand(const Map& map);

  // Where a step to `target` lands on a route of `n` locations: past either end, the robot
  // turns round there and walks the rest of the step back (*turned set). A uniform belief
  // stays uniform through the prediction. REQUIRES: n >= 1.
  static int ReflectAtEnds(int target, int n, bool* turned);

  // The size of a session's belief over `num_locations` tour locations and `speeds` speeds.
  static size_t StateSize(int num_locations, int speeds) {
    return static_cast<size_t>(speeds) * static_cast<size_t>(num_locations) + 1;
  }
  // Speeds run from -max_backward to max_forward in steps of half a location per frame.
  static constexpr int kSpeedsPerLocation = 2;
  int num_speeds() const { return kSpeedsPerLocation * (forward_ + backward_) + 1; }
  size_t state_size() const { return StateSize(num_locations_, num_speeds()); }

  int max_forward() const { return forward_; }
  int max_backward() const { return backward_; }

 private:
  void Predict(std::vector<float>* belief) const;
  void Observe(const FrameEvidence& evidence, std::vector<float>* belief) const;
  // Adds to each location's likelihood its neighbours' within the band, weighted by
  // spread_ (log_lik holds N locations, then off-map, which is left alone).
  void Spread(std::vector<double>* log_lik) const;
  SequenceAnswer Answer(const std::vector<float>& belief, uint32_t frames) const;

  // Constant after construction.
  const int num_locations_;
  const int tolerance_;
  const double temperature_;
  const SequenceOptions options_;
  int forward_ = 0;
  int backward_ = 0;
  // evidence_spread^d for d = 0..the map's band; empty when evidence_spread is 0.
  std::vector<double> spread_;
  // Per speed, where one frame takes the robot: whole locations and their weights (sum 1).
  struct Step {
    int locations;
    float weight;
  };
  std::vector<std::vector<Step>> steps_;
};

}  // namespace sceneloc
