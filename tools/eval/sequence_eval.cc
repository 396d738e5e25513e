#include "tools/eval/sequence_eval.h"

#include <algorithm>
#include <cstdlib>
#include <numeric>
#include <random>

#include "common/matching/sequence_filter.h"
#include "common/util/timer.h"

namespace sceneloc {
namespace {

// Whether a shuffle of runs puts some run straight after its file-order predecessor.
bool KeepsANeighbour(const std::vector<int>& runs) {
  for (size_t i = 1; i < runs.size(); ++i) {
    if (runs[i] == runs[i - 1] + 1) return true;
  }
  return false;
}

}  // namespace

std::vector<int> KidnapOrder(size_t n, int segments, uint32_t seed, bool reversed) {
  std::vector<int> order(n);
  std::iota(order.begin(), order.end(), 0);
  if (segments <= 1 || n < 2) {
    if (reversed) std::reverse(order.begin(), order.end());
    return order;
  }
  const size_t runs = std::min<size_t>(static_cast<size_t>(segments), n);
  std::vector<int> run_order(runs);
  std::iota(run_order.begin(), run_order.end(), 0);
  std::mt19937 rng(seed);
  // A few hundred tries find a shuffle without neighbours whenever one exists (runs >= 3).
  for (int attempt = 0; attempt < 1000; ++attempt) {
    std::shuffle(run_order.begin(), run_order.end(), rng);
    if (runs < 3 || !KeepsANeighbour(run_order)) break;
  }
  std::vector<int> out;
  out.reserve(n);
  for (const int r : run_order) {
    const size_t begin = n * r / runs, end = n * (r + 1) / runs;
    for (size_t i = begin; i < end; ++i) out.push_back(static_cast<int>(i));
  }
  if (reversed) std::reverse(out.begin(), out.end());
  return out;
}

SequenceRun RunSequence(const std::vector<QueryOutcome>& outcomes, const Map& map,
                        const SequenceOptions& options, const std::vector<int>& order) {
  const SequenceFilter filter(map, options);
  SequenceRun run;
  run.filtered = outcomes;
  SequenceState state;
  std::vector<double> ms;
  const int tolerance = map.options.tolerance;
  int since_jump_correct = -1, since_jump_localised = -1;  // -1: recovered (or no jump yet)
  for (size_t k = 0; k < order.size(); ++k) {
    const int q = order[k];
    const bool jump = k > 0 && std::abs(order[k] - order[k - 1]) != 1;
    if (jump) {
      if (since_jump_correct >= 0) run.relocalisation.to_correct.push_back(since_jump_correct);
      if (since_jump_localised >= 0) {
        run.relocalisation.to_localised.push_back(since_jump_localised);
      }
      since_jump_correct = since_jump_localised = 0;
    }
    FrameEvidence evidence{outcomes[q].location_scores, outcomes[q].in_map};
    Stopwatch watch;
    const SequenceAnswer a = filter.Update(evidence, &state);
    ms.push_back(watch.Milliseconds());
    QueryOutcome& o = run.filtered[q];
    o.ours.predicted = a.location;
    o.ours.confidence = static_cast<float>(a.probability);
    const bool correct = o.truth >= 0 && std::abs(a.location - o.truth) <= tolerance;
    const bool localised = correct && a.decision == Decision::kLocalised;
    if (since_jump_correct >= 0) {
      if (correct) {
        run.relocalisation.to_correct.push_back(since_jump_correct);
        since_jump_correct = -1;
      } else {
        ++since_jump_correct;
      }
    }
    if (since_jump_localised >= 0) {
      if (localised) {
        run.relocalisation.to_localised.push_back(since_jump_localised);
        since_jump_localised = -1;
      } else {
        ++since_jump_localised;
      }
    }
  }
  if (since_jump_correct >= 0) run.relocalisation.to_correct.push_back(since_jump_correct);
  if (since_jump_localised >= 0) run.relocalisation.to_localised.push_back(since_jump_localised);
  if (!ms.empty()) {
    std::nth_element(ms.begin(), ms.begin() + ms.size() / 2, ms.end());
    run.filter_ms_median = ms[ms.size() / 2];
  }
  return run;
}

}  // namespace sceneloc
