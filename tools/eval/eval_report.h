// sceneloc-eval's report (tools/eval_main.cc): the table it prints and the JSON file it
// writes (--json), from the figures of one run.
//
// Thread-safe: free functions over caller-owned figures (printing is to stdout).
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/map/map.h"
#include "common/matching/localiser.h"
#include "tools/eval/evaluation.h"
#include "tools/eval/sequence_eval.h"

namespace sceneloc {

// Frames of places that are not on the route: how many would be LOCALISED.
struct Negatives {
  size_t frames = 0;
  size_t accepted = 0;
  float max_confidence = 0;
};

// What a session run adds: the single-frame figures of the same frames, the filter's time,
// and for a kidnap the frames to find the robot again after each jump.
struct SessionReport {
  MethodSummary single;
  // The frames one at a time as the session's requests get them (SequenceRun::in_session).
  MethodSummary in_session;
  const SequenceRun* run = nullptr;
  std::vector<QueryOutcome> single_outcomes;
  int kidnap = 0;
  bool reversed = false;  // the queries in reverse file order (--reverse)
};

// Everything one report shows. The pointees belong to the caller and must be set, except
// `negatives` and `session`, which are null when that part did not run.
struct EvalReport {
  // The run, as the table's heading names it.
  std::string map_path;
  std::string queries_dir;
  std::string negatives_dir;
  int threads = 1;
  int tolerance = 2;  // the headline tolerance, frames (--tolerance)
  bool with_baseline = false;
  double load_ms = 0;  // time to load the map
  // Its figures.
  const EvalSummary* summary = nullptr;
  const std::vector<QueryOutcome>* outcomes = nullptr;  // one per query, in query order
  const Map* map = nullptr;
  const MatchOptions* options = nullptr;
  const Negatives* negatives = nullptr;
  const SessionReport* session = nullptr;
};

// The summary table, on stdout.
void PrintReport(const EvalReport& report);

// One line per query on stdout: its answer, LOCALISED or UNKNOWN at `threshold`, and
// whether it is within `tolerance` frames of the truth.
void PrintAnswers(const std::vector<QueryOutcome>& outcomes,
                  const std::vector<std::string>& tour_names, int tolerance, double threshold);

// The whole report as JSON: figures per method, timings, negatives, session, per query.
nlohmann::json ReportJson(const EvalReport& report);

}  // namespace sceneloc
