#include "tools/eval/sequence_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numeric>
#include <random>

#include "common/matching/sequence_filter.h"
#include "common/util/timer.h"
#include "tools/eval/confidence_metrics.h"

namespace sceneloc {
namespace {

// Whether a shuffle of runs puts some run straight after its file-order predecessor.
bool KeepsANeighbour(const std::vector<int>& runs) {
  for (size_t i = 1; i < runs.size(); ++i) {
    if (runs[i] == runs[i - 1] + 1) return true;
  }
  return false;
}

// The single-frame answer of `o` read with `camera` (a session's), as the server answers a
// session's request.
MethodOutcome OwnAnswerWithCamera(const QueryOutcome& o, const Map& map,
                                  const MatchOptions& options, double camera) {
  if (camera == o.camera_log_scale || o.ranked.empty()) return o.ours;
  LocaliseResult r = KeptResult(o);
  MatchOptions read = options;
  read.camera_log_scale = camera;
  read.camera_log_doubt = 0;  // measured by the session
  ReadWithCamera(map, read, &r);
  MethodOutcome out = o.ours;
  out.predicted = r.ranked[0].index;
  out.confidence = r.confidence;
  return out;
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
                        const MatchOptions& options, const std::vector<int>& order,
                        std::optional<double> stated_camera) {
  const SequenceFilter filter(map, options.sequence);
  SequenceRun run;
  run.filtered = outcomes;
  run.in_session = outcomes;
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
    FrameEvidence evidence{outcomes[q].location_scores, outcomes[q].in_map, outcomes[q].candidates,
                           options, stated_camera};
    evidence.fusion.camera_log_scale = outcomes[q].camera_log_scale;  // as EvidenceOf
    evidence.fusion.camera_log_doubt = outcomes[q].camera_log_doubt;
    evidence.fusion.camera_known = true;
    Stopwatch watch;
    const SequenceAnswer a = filter.Update(evidence, &state);
    ms.push_back(watch.Milliseconds());
    run.in_session[q].ours = OwnAnswerWithCamera(outcomes[q], map, options, a.camera_log_scale);
    QueryOutcome& o = run.filtered[q];
    o.ours.predicted = a.location;
    o.ours.confidence = static_cast<float>(a.probability);
    const bool correct = o.truth >= 0 && std::abs(a.location - o.truth) <= tolerance;
    run.steps.push_back(
        {q, a.location, a.probability, correct, a.decision == Decision::kLocalised});
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

std::vector<Walk> StandardWalks(size_t n) {
  const int m = static_cast<int>(n);
  std::vector<Walk> walks;
  const auto add = [&walks](const char* name, const char* description, std::vector<int> order) {
    walks.push_back({name, description, std::move(order)});
  };
  std::vector<int> in_order(n);
  std::iota(in_order.begin(), in_order.end(), 0);
  add("in_order", "the queries in route order", in_order);
  add("reversed", "backing up the whole route",
      std::vector<int>(in_order.rbegin(), in_order.rend()));
  std::vector<int> there_and_back;
  const int turn = m * 6 / 10, back_to = m * 2 / 10;
  for (int q = 0; q < turn; ++q) there_and_back.push_back(q);
  for (int q = turn - 2; q > back_to; --q) there_and_back.push_back(q);
  for (int q = back_to + 1; q < m; ++q) there_and_back.push_back(q);
  add("there_and_back", "to 60% of the route, back to 20%, on to the end", there_and_back);
  for (const int pace : {2, 3}) {
    std::vector<int> order;
    for (int q = 0; q < m; q += pace) order.push_back(q);
    add(pace == 2 ? "pace_2" : "pace_3",
        pace == 2 ? "every 2nd query: twice the tour's pace" : "every 3rd query: three times",
        order);
  }
  std::vector<int> slow;
  for (int q = 0; q < m; ++q) slow.insert(slow.end(), 3, q);
  add("slow_3", "each query 3 times: a third of the tour's pace", slow);
  std::vector<int> stop(in_order.begin(), in_order.begin() + m / 2);
  stop.insert(stop.end(), 10, m / 2);
  for (int q = m / 2 + 1; q < m; ++q) stop.push_back(q);
  add("stop_10", "standing 10 frames halfway", stop);
  // A robot that keeps speeding up and slowing down: its pace 3^sin(2 pi k / 40) locations
  // per frame at step k, from the tour's up to three times it, back, down to a third and
  // back every 40 frames (at most a third faster or slower from one frame to the next).
  std::vector<int> varying;
  double at = 0;
  for (int k = 0; at < m - 0.5; ++k) {
    varying.push_back(static_cast<int>(std::lround(at)));
    at += std::pow(3.0, std::sin(2 * M_PI * k / kVaryingPacePeriod));
  }
  add("pace_varying", "a pace between a third and three times the tour's, changing every frame",
      varying);
  return walks;
}

WalkSummary SummariseWalk(const Walk& walk, const std::vector<QueryOutcome>& outcomes,
                          const Map& map, const MatchOptions& options) {
  const SequenceRun run = RunSequence(outcomes, map, options, walk.order);
  WalkSummary s;
  s.name = walk.name;
  s.steps = static_cast<int>(run.steps.size());
  std::vector<float> confidence;
  std::vector<bool> correct;
  int localised_right = 0;
  for (const SequenceStep& step : run.steps) {
    confidence.push_back(static_cast<float>(step.probability));
    correct.push_back(step.correct);
    s.localised += step.localised ? 1 : 0;
    localised_right += step.localised && step.correct ? 1 : 0;
  }
  if (s.steps == 0) return s;
  const ConfidenceMetrics m =
      ComputeConfidenceMetrics(confidence, correct, options.sequence.min_confidence);
  s.rate = m.accuracy;
  s.ece = m.ece;
  s.ece_floor = m.ece_floor;
  s.localised_precision = s.localised > 0 ? static_cast<double>(localised_right) / s.localised : 1;
  return s;
}

KidnapSummary SummariseKidnaps(const std::vector<QueryOutcome>& outcomes, const Map& map,
                               const MatchOptions& options, int segments, int seeds) {
  KidnapSummary k;
  k.segments = segments;
  k.seeds = seeds;
  std::vector<double> frames;
  for (int seed = 1; seed <= seeds; ++seed) {
    const SequenceRun run =
        RunSequence(outcomes, map, options,
                    KidnapOrder(outcomes.size(), segments, static_cast<uint32_t>(seed)));
    for (const int f : run.relocalisation.to_correct) {
      frames.push_back(f);
      k.worst = std::max(k.worst, f);
    }
  }
  k.jumps = static_cast<int>(frames.size());
  if (!frames.empty()) k.median = ComputePercentiles(frames).median;
  return k;
}

}  // namespace sceneloc
