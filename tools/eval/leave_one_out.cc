#include "tools/eval/leave_one_out.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "common/matching/localiser.h"
#include "tools/eval/report_json.h"

namespace sceneloc {
namespace {

bool Correct(const MethodOutcome& o, int truth, int tolerance) {
  return o.predicted >= 0 && std::abs(o.predicted - truth) <= tolerance;
}

// Mean log-loss of the answers' confidences against their correctness.
double LogLoss(const std::vector<HeldOutInput>& sets, const MatchOptions& match,
               const Judging& judging, const ConfidenceConstants& constants) {
  double loss = 0;
  size_t n = 0;
  for (const HeldOutInput& set : sets) {
    const std::vector<MethodOutcome> read =
        ReadWithConstants(*set.shell, match, *set.outcomes, constants);
    for (size_t q = 0; q < read.size(); ++q) {
      const double p = std::clamp(static_cast<double>(read[q].confidence), 1e-6, 1 - 1e-6);
      loss -= Correct(read[q], (*set.outcomes)[q].truth, judging.tolerance) ? std::log(p)
                                                                            : std::log(1 - p);
      ++n;
    }
  }
  return n == 0 ? 0 : loss / static_cast<double>(n);
}

std::vector<QueryOutcome> WithOurs(const std::vector<QueryOutcome>& outcomes,
                                   const std::vector<MethodOutcome>& ours) {
  std::vector<QueryOutcome> out = outcomes;
  for (size_t q = 0; q < out.size(); ++q) out[q].ours = ours[q];
  return out;
}

// Answers at `threshold` or above: how many, how many right, how many grossly wrong.
void CountAbove(const std::vector<QueryOutcome>& outcomes, const std::vector<MethodOutcome>& ours,
                double threshold, int tolerance, int* accepted, int* right, int* gross) {
  for (size_t q = 0; q < ours.size(); ++q) {
    if (ours[q].confidence < threshold || ours[q].predicted < 0) continue;
    const int off = std::abs(ours[q].predicted - outcomes[q].truth);
    if (accepted != nullptr) ++*accepted;
    if (right != nullptr && off <= tolerance) ++*right;
    if (gross != nullptr && off > HeldOutSummary::kGrossFrames) ++*gross;
  }
}

std::vector<MethodOutcome> OursOf(const std::vector<QueryOutcome>& outcomes) {
  std::vector<MethodOutcome> ours;
  for (const QueryOutcome& o : outcomes) ours.push_back(o.ours);
  return ours;
}

}  // namespace

ConfidenceConstants ConstantsOf(const TrainOptions& options) {
  return {options.confidence_temperature, options.map_evidence_slope, options.map_evidence_offset};
}

Map MapShell(const Map& map) {
  Map shell;
  shell.options = map.options;
  shell.calibration = map.calibration;
  shell.image_width = map.image_width;
  shell.image_height = map.image_height;
  shell.image_names = map.image_names;
  // The confidence reads an answer's look-alikes; a session's motion band, the landmarks'
  // observation counts.
  shell.lookalike_offsets = map.lookalike_offsets;
  shell.lookalike_location = map.lookalike_location;
  shell.lookalike_ratio = map.lookalike_ratio;
  shell.observation_offsets = map.observation_offsets;
  return shell;
}

std::vector<MethodOutcome> ReadWithConstants(const Map& shell, const MatchOptions& match,
                                             const std::vector<QueryOutcome>& outcomes,
                                             const ConfidenceConstants& constants) {
  Map map = shell;
  map.options.confidence_temperature = constants.temperature;
  map.options.map_evidence_slope = constants.slope;
  map.options.map_evidence_offset = constants.offset;
  std::vector<MethodOutcome> out;
  out.reserve(outcomes.size());
  for (const QueryOutcome& o : outcomes) {
    MethodOutcome read = o.ours;
    if (!o.ranked.empty()) {
      LocaliseResult r = KeptResult(o);
      MatchOptions options = match;
      options.camera_log_scale = o.camera_log_scale;
      options.camera_log_doubt = o.camera_log_doubt;
      ReadWithCamera(map, options, &r);
      read.predicted = r.ranked[0].index;
      read.confidence = r.confidence;
    }
    out.push_back(read);
  }
  return out;
}

ConfidenceConstants FitConstants(const std::vector<HeldOutInput>& sets, const MatchOptions& match,
                                 const Judging& judging, const ConfidenceConstants& start) {
  ConfidenceConstants best = start;
  double best_loss = LogLoss(sets, match, judging, best);
  // Each constant in turn over a few steps either side (the temperature and the slope by
  // factors, the offset by differences), the steps halved (on a log scale) each round.
  double factor = 2.0, step = 1.0;
  for (int round = 0; round < 4; ++round) {
    for (int which = 0; which < 3; ++which) {
      for (int k = -3; k <= 3; ++k) {
        if (k == 0) continue;
        ConfidenceConstants c = best;
        const double f = std::pow(factor, k / 3.0);
        if (which == 0) c.temperature *= f;
        if (which == 1) c.slope *= f;
        if (which == 2) c.offset += step * k / 3.0;
        const double loss = LogLoss(sets, match, judging, c);
        if (loss < best_loss) {
          best_loss = loss;
          best = c;
        }
      }
    }
    factor = std::sqrt(factor);
    step /= 2;
  }
  return best;
}

std::vector<HeldOutSummary> LeaveOneSetOut(const std::vector<HeldOutInput>& sets,
                                           const MatchOptions& match, const Judging& judging) {
  std::vector<HeldOutSummary> out;
  for (const HeldOutInput& held : sets) {
    std::vector<HeldOutInput> others;
    for (const HeldOutInput& s : sets) {
      if (s.family != held.family) others.push_back(s);
    }
    HeldOutSummary summary;
    summary.name = held.name;
    const ConfidenceConstants shipped = ConstantsOf(held.shell->options);
    summary.fitted = others.empty() ? shipped : FitConstants(others, match, judging, shipped);
    const std::vector<MethodOutcome> read =
        ReadWithConstants(*held.shell, match, *held.outcomes, summary.fitted);
    summary.summary = SummariseMethod(WithOurs(*held.outcomes, read), Method::kOurs, judging);
    summary.shipped = SummariseMethod(*held.outcomes, Method::kOurs, judging);
    for (size_t q = 0; q < read.size(); ++q) {
      summary.confidence.push_back(read[q].confidence);
      summary.correct.push_back(Correct(read[q], (*held.outcomes)[q].truth, judging.tolerance));
    }
    CountAbove(*held.outcomes, read, 0.95, judging.tolerance, &summary.accepted_95,
               &summary.right_95, nullptr);
    CountAbove(*held.outcomes, read, 0.99, judging.tolerance, nullptr, nullptr, &summary.gross_99);
    CountAbove(*held.outcomes, OursOf(*held.outcomes), 0.99, judging.tolerance, nullptr, nullptr,
               &summary.shipped_gross_99);
    if (held.session != nullptr) {
      summary.has_session = true;
      summary.session = SummariseMethod(WithOurs(*held.outcomes, *held.session), Method::kOurs,
                                        {judging.tolerance, match.sequence.min_confidence});
      CountAbove(*held.outcomes, *held.session, 0.95, judging.tolerance,
                 &summary.session_accepted_95, &summary.session_right_95, nullptr);
      CountAbove(*held.outcomes, *held.session, 0.99, judging.tolerance, nullptr, nullptr,
                 &summary.session_gross_99);
    }
    out.push_back(std::move(summary));
  }
  return out;
}

void PrintLeaveOneOut(const std::vector<HeldOutSummary>& held, double threshold) {
  std::printf("\nleave-one-set-out: the confidence's constants fitted without each set's family\n");
  std::printf("%-16s %-20s %-15s %-15s %-15s %-9s\n", "set", "T / slope / offset", "ECE (floor)",
              "precision", ">=0.95 right", ">=0.99 off>5");
  for (const HeldOutSummary& h : held) {
    const ConfidenceMetrics& c = h.summary.confidence;
    const ConfidenceMetrics& s = h.shipped.confidence;
    char constants[64], ece[48], precision[48], right[48];
    std::snprintf(constants, sizeof(constants), "%.3f/%.2f/%.2f", h.fitted.temperature,
                  h.fitted.slope, h.fitted.offset);
    std::snprintf(ece, sizeof(ece), "%.3f (%.3f)", c.ece, c.ece_floor);
    std::snprintf(precision, sizeof(precision), "%.3f [%.3f]", c.accepted_precision,
                  s.accepted_precision);
    std::snprintf(right, sizeof(right), "%d/%d", h.right_95, h.accepted_95);
    std::printf("%-16s %-20s %-15s %-15s %-15s %d [%d]\n", h.name.c_str(), constants, ece,
                precision, right, h.gross_99, h.shipped_gross_99);
  }
  const ConfidenceMetrics pooled = PooledHeldOut(held, threshold);
  std::printf(
      "pooled, held out: ECE %.3f (floor %.3f); precision: of the answers at >= %.2f, "
      "the share right [with the shipped constants]\n",
      pooled.ece, pooled.ece_floor, threshold);
  if (std::none_of(held.begin(), held.end(), [](const HeldOutSummary& h) { return h.has_session; }))
    return;
  std::printf(
      "\nsessions (the file order as one robot; the filter reads none of the fitted "
      "constants, so as run)\n");
  std::printf("%-16s %-15s %-15s %-15s %-9s\n", "set", "ECE (floor)", "precision", ">=0.95 right",
              ">=0.99 off>5");
  for (const HeldOutSummary& h : held) {
    if (!h.has_session) continue;
    const ConfidenceMetrics& c = h.session.confidence;
    char ece[48], precision[48], right[48];
    std::snprintf(ece, sizeof(ece), "%.3f (%.3f)", c.ece, c.ece_floor);
    std::snprintf(precision, sizeof(precision), "%.3f", c.accepted_precision);
    std::snprintf(right, sizeof(right), "%d/%d", h.session_right_95, h.session_accepted_95);
    std::printf("%-16s %-15s %-15s %-15s %d\n", h.name.c_str(), ece, precision, right,
                h.session_gross_99);
  }
}

ConfidenceMetrics PooledHeldOut(const std::vector<HeldOutSummary>& held, double threshold) {
  std::vector<float> confidence;
  std::vector<bool> correct;
  for (const HeldOutSummary& h : held) {
    confidence.insert(confidence.end(), h.confidence.begin(), h.confidence.end());
    correct.insert(correct.end(), h.correct.begin(), h.correct.end());
  }
  return ComputeConfidenceMetrics(confidence, correct, threshold);
}

nlohmann::json LeaveOneOutJson(const std::vector<HeldOutSummary>& held, double threshold) {
  nlohmann::json out = nlohmann::json::array();
  for (const HeldOutSummary& h : held) {
    out.push_back({{"set", h.name},
                   {"fitted",
                    {{"temperature", h.fitted.temperature},
                     {"slope", h.fitted.slope},
                     {"offset", h.fitted.offset}}},
                   {"held_out", MethodJson(h.summary)},
                   {"shipped", MethodJson(h.shipped)},
                   {"accepted_95", h.accepted_95},
                   {"right_95", h.right_95},
                   {"gross_99", h.gross_99},
                   {"shipped_gross_99", h.shipped_gross_99}});
    if (h.has_session) {
      out.back()["session"] = {{"summary", MethodJson(h.session)},
                               {"accepted_95", h.session_accepted_95},
                               {"right_95", h.session_right_95},
                               {"gross_99", h.session_gross_99}};
    }
  }
  return {{"sets", out}, {"pooled", ConfidenceJson(PooledHeldOut(held, threshold))}};
}

}  // namespace sceneloc
