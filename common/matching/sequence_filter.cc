#include "common/matching/sequence_filter.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "common/matching/confidence.h"

namespace sceneloc {
namespace {

// The stationary share of off-map of the enter/leave chain: where a fresh session starts.
double StationaryOffMap(const SequenceOptions& o) {
  return o.leave + o.enter > 0 ? o.leave / (o.leave + o.enter) : 0;
}

void Normalise(std::vector<float>* v) {
  const double total = std::accumulate(v->begin(), v->end(), 0.0);
  if (!(total > 0) || !std::isfinite(total)) {  // cannot happen with finite evidence
    std::fill(v->begin(), v->end(), 1.0f / static_cast<float>(v->size()));
    return;
  }
  for (float& x : *v) x = static_cast<float>(x / total);
}

}  // namespace

FrameEvidence EvidenceOf(const LocaliseResult& result, const Map& map) {
  FrameEvidence e;
  e.location_scores = result.location_scores;
  if (map.calibration.valid && result.nearest_holistic_distance >= 0) {
    e.in_map = InMapProbability(map, result.nearest_holistic_distance);
  }
  return e;
}

int SequenceFilter::MotionBand(const Map& map) {
  const size_t landmarks = map.observation_offsets.empty() ? 0 : map.observation_offsets.size() - 1;
  if (landmarks == 0) return 2;
  std::vector<uint32_t> seen(landmarks);
  for (size_t g = 0; g < landmarks; ++g) {
    seen[g] = map.observation_offsets[g + 1] - map.observation_offsets[g];
  }
  std::nth_element(seen.begin(), seen.begin() + landmarks / 2, seen.end());
  return std::max<int>(2, static_cast<int>(seen[landmarks / 2]));
}

SequenceFilter::SequenceFilter(const Map& map, const SequenceOptions& options)
    : num_locations_(map.num_images()),
      tolerance_(map.options.tolerance),
      temperature_(map.options.confidence_temperature),
      options_(options) {
  const int band = options.max_forward < 0 || options.max_backward < 0 ? MotionBand(map) : 0;
  forward_ = options.max_forward >= 0 ? options.max_forward : band;
  backward_ = options.max_backward >= 0 ? options.max_backward : band;
}

int SequenceFilter::ReflectAtEnds(int target, int n, bool* turned) {
  *turned = false;
  // Mirrors between the end locations and one past them: -1 -> 0, -2 -> 1, n -> n - 1.
  // Repeated only when a step is longer than the whole route.
  while (target < 0 || target >= n) {
    target = target < 0 ? -target - 1 : 2 * n - 1 - target;
    *turned = !*turned;
  }
  return target;
}

void SequenceFilter::Predict(std::vector<float>* belief) const {
  const int n = num_locations_;
  std::vector<float>& b = *belief;
  const double in_mass = std::accumulate(b.begin(), b.begin() + 2 * n, 0.0);
  const double off = b[2 * n];
  const double turn = options_.reverse;
  // Each direction of travel after a possible turn, then its step: 0..forward_ locations
  // up the route, or 0..backward_ down it, each equally likely. A step past either end of
  // the route turns the robot round there and it walks the rest of the step back (ReflectAt
  // Ends): kept at the end instead, every step past it would pile up on the end location
  // and a robot standing near the start of the route would be answered at its first frame.
  std::vector<float> up(static_cast<size_t>(n), 0.0f), down(static_cast<size_t>(n), 0.0f);
  const auto land = [&](int target, bool upwards, float w) {
    bool turned = false;
    const int at = ReflectAtEnds(target, n, &turned);
    (upwards != turned ? up : down)[static_cast<size_t>(at)] += w;
  };
  const double up_step = 1.0 / (forward_ + 1), down_step = 1.0 / (backward_ + 1);
  for (int i = 0; i < n; ++i) {
    const double going_up = (1 - turn) * b[i] + turn * b[n + i];
    const double going_down = (1 - turn) * b[n + i] + turn * b[i];
    if (going_up != 0) {
      const auto w = static_cast<float>(going_up * up_step);
      for (int d = 0; d <= forward_; ++d) land(i + d, true, w);
    }
    if (going_down != 0) {
      const auto w = static_cast<float>(going_down * down_step);
      for (int d = 0; d <= backward_; ++d) land(i - d, false, w);
    }
  }
  // The kidnap floor and the way back onto the route: any location, either direction.
  const double jump_each = options_.jump * in_mass / (2 * n);
  const double enter_each = options_.enter * off / (2 * n);
  const auto arrive = [&](float moved) {
    return static_cast<float>((1 - options_.leave) * ((1 - options_.jump) * moved + jump_each) +
                              enter_each);
  };
  for (int j = 0; j < n; ++j) {
    b[j] = arrive(up[j]);
    b[n + j] = arrive(down[j]);
  }
  b[2 * n] = static_cast<float>(options_.leave * in_mass + (1 - options_.enter) * off);
}

void SequenceFilter::Observe(const FrameEvidence& evidence, std::vector<float>* belief) const {
  const int n = num_locations_;
  const std::vector<float>& s = evidence.location_scores;
  const bool has_scores =
      s.size() == static_cast<size_t>(n) &&
      *std::max_element(s.begin(), s.end()) != *std::min_element(s.begin(), s.end());
  if (!has_scores && evidence.in_map < 0) return;  // nothing observed: prediction only
  const double p_in = evidence.in_map < 0 ? 0.5 : std::clamp(evidence.in_map, 1e-4, 1 - 1e-4);
  const double gamma = options_.evidence_weight;
  // log P(frame | l) up to a constant shared by every state: the single-frame posterior
  // over a uniform prior (even odds of in-map, 1/N per location) is a likelihood ratio.
  // The frame says nothing about the direction of travel: both halves get the same.
  std::vector<double> log_lik(static_cast<size_t>(n) + 1, std::log(p_in));
  if (has_scores) {
    const float top = *std::max_element(s.begin(), s.end());
    double z = 0;
    for (int l = 0; l < n; ++l) z += std::exp((s[l] - top) / temperature_);
    const double offset = std::log(p_in) + std::log(static_cast<double>(n)) - std::log(z);
    for (int l = 0; l < n; ++l) log_lik[l] = (s[l] - top) / temperature_ + offset;
  }
  log_lik[n] = std::log(1 - p_in);
  const double top = *std::max_element(log_lik.begin(), log_lik.end());
  std::vector<float>& b = *belief;
  for (int l = 0; l < n; ++l) {
    const auto w = static_cast<float>(std::exp(gamma * (log_lik[l] - top)));
    b[l] *= w;
    b[n + l] *= w;
  }
  b[2 * n] *= static_cast<float>(std::exp(gamma * (log_lik[n] - top)));
  Normalise(belief);
}

SequenceAnswer SequenceFilter::Answer(const std::vector<float>& belief, uint32_t frames) const {
  const int n = num_locations_;
  std::vector<double> at(static_cast<size_t>(n));  // either direction of travel
  for (int l = 0; l < n; ++l) at[l] = static_cast<double>(belief[l]) + belief[n + l];
  SequenceAnswer a;
  a.location = static_cast<int>(std::max_element(at.begin(), at.end()) - at.begin());
  const int low = std::max(0, a.location - tolerance_);
  const int high = std::min(n - 1, a.location + tolerance_);
  a.probability = std::accumulate(at.begin() + low, at.begin() + high + 1, 0.0);
  a.off_map = belief[2 * n];
  a.frames = frames;
  a.decision = a.probability >= options_.min_confidence ? Decision::kLocalised : Decision::kUnknown;
  return a;
}

SequenceAnswer SequenceFilter::Update(const FrameEvidence& evidence, SequenceState* state) const {
  const size_t size = StateSize(num_locations_);
  if (state->belief.size() != size) {
    const double off = StationaryOffMap(options_);
    state->belief.assign(size, static_cast<float>((1 - off) / (2 * num_locations_)));
    state->belief.back() = static_cast<float>(off);
    state->frames = 0;
  } else {
    Predict(&state->belief);
  }
  Observe(evidence, &state->belief);
  ++state->frames;
  return Answer(state->belief, state->frames);
}

}  // namespace sceneloc
