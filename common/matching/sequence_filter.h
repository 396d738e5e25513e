// A Bayes filter over a robot's frames (our addition to the paper, after the sequence
// methods of place recognition: SeqSLAM, RTAB-Map's hypotheses, FAB-MAP's motion model).
// Each frame is localised on its own (localiser.h); the filter combines that single-frame
// evidence with where the robot was a moment ago.
//
// The state is a belief over (tour location, direction of travel) for the map's N tour
// locations and the two directions along the route, plus one "off the map" state.
// One step, causal (an answer uses only the frames so far):
//   predict:  the robot turns round with probability `reverse`, then steps 0..max_forward
//             locations up the route if travelling up it, 0..max_backward down it if
//             travelling down, each step equally likely (a step past an end of the route
//             turns round there and walks back the rest); a kidnap floor spreads `jump` of
//             the mass over every location and direction, so a robot carried elsewhere is
//             found again; off-map enters and leaves at the rates below.
//   update:   belief'(l, d) *= P(frame | l)^evidence_weight, normalised. P(frame | l) is
//             the calibrated confidence's reading of the evidence (confidence.h): the fused
//             scores as a posterior exp(s_l / T) over locations times P(in the map), over
//             a uniform prior, i.e. a likelihood ratio. evidence_weight < 1 tempers it:
//             consecutive frames are not independent (the same look-alike fools both).
//   answer:   the location with the most belief over both directions.
// The direction is state, not a backward step at every frame: a robot that backs up keeps
// backing up, and one that walks on does not drift back towards where it was (a band with
// backward steps at every frame averaged less than one location per frame forward and
// answered behind the truth; measured in docs/results.md "Sessions").
// Cost: O(N (max_forward + max_backward)) per frame, memory 2N + 1 floats per session.
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
  // N locations travelling up the route (towards higher location numbers), the same N
  // travelling down it, then off-map; sums to 1. SequenceFilter::StateSize(N) values.
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

  // The band the map suggests: the median number of tour images its landmarks are seen in
  // (at least 2), in either direction of travel.
  static int MotionBand(const Map& map);

  // Where a step to `target` lands on a route of `n` locations: past either end, the robot
  // turns round there and walks the rest of the step back (*turned set). A uniform belief
  // stays uniform through the prediction. REQUIRES: n >= 1.
  static int ReflectAtEnds(int target, int n, bool* turned);

  // The size of a session's belief over `num_locations` tour locations.
  static size_t StateSize(int num_locations) { return 2 * static_cast<size_t>(num_locations) + 1; }

  int max_forward() const { return forward_; }
  int max_backward() const { return backward_; }

 private:
  void Predict(std::vector<float>* belief) const;
  void Observe(const FrameEvidence& evidence, std::vector<float>* belief) const;
  SequenceAnswer Answer(const std::vector<float>& belief, uint32_t frames) const;

  // Constant after construction.
  const int num_locations_;
  const int tolerance_;
  const double temperature_;
  const SequenceOptions options_;
  int forward_ = 0;
  int backward_ = 0;
};

}  // namespace sceneloc
