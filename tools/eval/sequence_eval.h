// Evaluation of the sequence filter (common/matching/sequence_filter.h): a query folder
// in file order as one session (sceneloc-eval --sequence), and the kidnapped robot
// (--kidnap N): the order cut into N segments that are shuffled, so the robot is carried
// elsewhere at every segment boundary; and the walks the accuracy suite runs over every
// set (StandardWalks): robots that back up, turn round, stop, or move faster or slower
// than the tour was recorded.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/map/map.h"
#include "common/matching/sequence_options.h"
#include "tools/eval/evaluation.h"

namespace sceneloc {

// 0..n-1 cut into `segments` nearly equal runs, the runs shuffled (seeded), so that no run
// follows the one it followed in file order (when there are at least 3). segments <= 1:
// file order. With `reversed`, the whole order backwards (a robot backing up the route:
// each run walked down it, and no run follows the one it preceded in file order).
std::vector<int> KidnapOrder(size_t n, int segments, uint32_t seed, bool reversed = false);

// How soon the filter finds the robot again after each jump of a kidnap order.
struct Relocalisation {
  // Per jump: frames answered wrong (beyond the tolerance, or not LOCALISED for
  // `to_localised`) from the jump on before the first right one; a segment that never
  // recovers counts its whole length.
  std::vector<int> to_correct;    // first answer within the tolerance
  std::vector<int> to_localised;  // first answer within the tolerance and LOCALISED
};

// One step of a session: the query sent and the session's answer.
struct SequenceStep {
  int query = 0;
  int predicted = -1;
  double probability = 0;  // the session's probability within the tolerance
  bool correct = false;    // within the tolerance of the query's truth
  bool localised = false;  // LOCALISED
};

struct SequenceRun {
  // The outcomes with `ours` replaced by the session's answers (index and truth as given;
  // confidence = the session's probability within the tolerance). A query sent more than
  // once keeps its last answer.
  std::vector<QueryOutcome> filtered;
  // The outcomes with `ours` replaced by the single-frame answers as the session's requests
  // get them: read with the camera the session read each frame with (ReadWithCamera;
  // LocaliseReply.camera_scale). A query sent more than once keeps its last.
  std::vector<QueryOutcome> in_session;
  std::vector<SequenceStep> steps;  // every step, in order
  Relocalisation relocalisation;
  double filter_ms_median = 0;  // the filter's own time per frame
};

// Runs one session over `outcomes` (single-frame results already in, localised with
// `options`; the session's filter from options.sequence) in `order`. A jump
// (for Relocalisation) is a step between frames that are not neighbours in file order,
// either way.
// REQUIRES: options.Validate().ok(); order holds indices of the outcomes (a query may come
// more than once, or not at all).
// `stated_camera`: the robot camera's log scale as its client states it
// (LocaliseRequest.camera_scale; the outcomes localised with it), which the session reads
// every frame with instead of what it learns.
SequenceRun RunSequence(const std::vector<QueryOutcome>& outcomes, const Map& map,
                        const MatchOptions& options, const std::vector<int>& order,
                        std::optional<double> stated_camera = std::nullopt);

// A robot's walk along the route of a query folder in route order: the query it sends
// at each step.
struct Walk {
  std::string name;
  std::string description;
  std::vector<int> order;
};

// The walks over n queries (n >= 1): "in_order"; "reversed" (backing up the whole route);
// "there_and_back" (to 60%, back to 20%, then on to the end); "pace_2" and "pace_3" (every
// 2nd / 3rd query: a robot two or three times the tour's pace); "slow_3" (each query 3
// times: a third of it); "stop_10" (10 frames standing halfway); "pace_varying" (a pace that
// changes every frame, from the tour's to three times it, back, to a third and back every
// kVaryingPacePeriod frames).
std::vector<Walk> StandardWalks(size_t n);
constexpr int kVaryingPacePeriod = 40;

struct WalkSummary {
  std::string name;
  int steps = 0;
  double rate = 0;  // answers within the tolerance
  double ece = 0;   // of the session's probability (confidence_metrics.h)
  double ece_floor = 0;
  int localised = 0;               // LOCALISED answers
  double localised_precision = 1;  // the share of them within the tolerance
};

// One session over `outcomes` along `walk`.
WalkSummary SummariseWalk(const Walk& walk, const std::vector<QueryOutcome>& outcomes,
                          const Map& map, const MatchOptions& options);

// The kidnapped robot over `seeds` shuffles of `segments` segments (KidnapOrder, seeds 1..
// seeds): frames to an answer within the tolerance after each jump, over every jump.
struct KidnapSummary {
  int segments = 0;
  int seeds = 0;
  int jumps = 0;
  double median = 0;  // frames to a correct answer
  int worst = 0;
};
KidnapSummary SummariseKidnaps(const std::vector<QueryOutcome>& outcomes, const Map& map,
                               const MatchOptions& options, int segments, int seeds);

}  // namespace sceneloc
