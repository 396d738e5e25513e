// Leave-one-set-out: how the confidence does on a set whose frames no fitted constant saw.
//
// Three constants of the confidence are fitted on the development sets
// (TrainOptions::confidence_temperature, map_evidence_slope, map_evidence_offset;
// confidence.h). Here they are fitted again for each set with every set that shares its
// query frames left out (Gardens Point day and its seven generated variants are one family,
// both night sets another, the corridor a third), and the set's single-frame answers are
// read again with them (ReadWithCamera), as a building nobody tuned on would see them. The
// fit minimises the log-loss of "the answer is within the tolerance" over the other
// families' answers.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "common/map/map.h"
#include "tools/eval/confidence_metrics.h"
#include "tools/eval/evaluation.h"

namespace sceneloc {

// The fitted constants of the confidence.
struct ConfidenceConstants {
  double temperature = 0;
  double slope = 0;
  double offset = 0;
};
ConfidenceConstants ConstantsOf(const TrainOptions& options);

// What re-reading a set's answers needs: the set's single-frame outcomes (ours) and what
// of its map the confidence reads (MapShell).
struct HeldOutInput {
  std::string name;
  std::string family;  // sets of one family share query frames (their query folder)
  const Map* shell = nullptr;
  const std::vector<QueryOutcome>* outcomes = nullptr;
  // The set's answers as one robot's session (SetResult::session_outcomes), or null. The
  // session's filter reads none of the fitted constants (only the single frames' scores and
  // in-map probabilities), so they are reported as run.
  const std::vector<MethodOutcome>* session = nullptr;
};

// What of `map` the confidence and a session read: its options, calibration, frame, image
// names, look-alikes and the landmarks' observation counts; no landmarks.
Map MapShell(const Map& map);

// `outcomes`' answers read again with `constants` in place of the map's (the camera each
// was read with, `match`'s other settings). With the map's own constants they are the
// outcomes' own.
std::vector<MethodOutcome> ReadWithConstants(const Map& shell, const MatchOptions& match,
                                             const std::vector<QueryOutcome>& outcomes,
                                             const ConfidenceConstants& constants);

// The constants that minimise the mean log-loss of correctness (within judging.tolerance)
// over every query of `sets`, by coordinate search from `start`.
ConfidenceConstants FitConstants(const std::vector<HeldOutInput>& sets, const MatchOptions& match,
                                 const Judging& judging, const ConfidenceConstants& start);

struct HeldOutSummary {
  std::string name;
  ConfidenceConstants fitted;
  MethodSummary summary;  // the set's answers read with `fitted`
  MethodSummary shipped;  // with the shipped constants (the set's own run)
  int accepted_95 = 0;    // answers at confidence >= 0.95
  int right_95 = 0;       // of those, within the tolerance
  int gross_99 = 0;       // answers at >= 0.99 more than kGrossFrames off
  int shipped_gross_99 = 0;
  // Per query, read with `fitted`: its confidence and whether it is right.
  std::vector<float> confidence;
  std::vector<bool> correct;
  // The session's answers (HeldOutInput::session), judged at the session's min_confidence.
  bool has_session = false;
  MethodSummary session;
  int session_accepted_95 = 0;
  int session_right_95 = 0;
  int session_gross_99 = 0;
  static constexpr int kGrossFrames = 5;
};

// Every set of `sets` held out in turn (with its family), in order.
std::vector<HeldOutSummary> LeaveOneSetOut(const std::vector<HeldOutInput>& sets,
                                           const MatchOptions& match, const Judging& judging);

// Every held-out answer in one set of confidence figures (ECE beside its floor).
ConfidenceMetrics PooledHeldOut(const std::vector<HeldOutSummary>& held, double threshold);

// One table (stdout) and its JSON: per set, the constants fitted without its family, ECE
// beside its floor, the share of accepted answers right at `threshold` and at 0.95, the
// answers at 0.99 or more over kGrossFrames off, each beside the shipped constants' figure;
// then the same of the sessions, where there are.
void PrintLeaveOneOut(const std::vector<HeldOutSummary>& held, double threshold);
// {"sets": [per set], "pooled": ConfidenceJson of PooledHeldOut}
nlohmann::json LeaveOneOutJson(const std::vector<HeldOutSummary>& held, double threshold);

}  // namespace sceneloc
