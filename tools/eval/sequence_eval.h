// Evaluation of the sequence filter (common/matching/sequence_filter.h): a query folder
// in file order as one session (sceneloc-eval --sequence), and the kidnapped robot
// (--kidnap N): the order cut into N segments that are shuffled, so the robot is carried
// elsewhere at every segment boundary.
#pragma once

#include <cstdint>
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

struct SequenceRun {
  // The outcomes with `ours` replaced by the session's answers (index and truth as given;
  // confidence = the session's probability within the tolerance).
  std::vector<QueryOutcome> filtered;
  Relocalisation relocalisation;
  double filter_ms_median = 0;  // the filter's own time per frame
};

// Runs one session over `outcomes` (single-frame results already in) in `order`. A jump
// (for Relocalisation) is a step between frames that are not neighbours in file order,
// either way.
// REQUIRES: options.Validate().ok(); order a permutation of the outcomes' indices.
SequenceRun RunSequence(const std::vector<QueryOutcome>& outcomes, const Map& map,
                        const SequenceOptions& options, const std::vector<int>& order);

}  // namespace sceneloc
