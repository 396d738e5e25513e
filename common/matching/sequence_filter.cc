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
  backward_ = options.max_backward >= 0 ? options.max_backward : std::max(1, band / 2);
  kernel_.assign(static_cast<size_t>(backward_ + forward_ + 1), 1.0f);
  for (int d = 0; d < backward_; ++d) kernel_[d] = static_cast<float>(options.backward_weight);
  Normalise(&kernel_);
}

void SequenceFilter::Predict(std::vector<float>* belief) const {
  const int n = num_locations_;
  std::vector<float>& b = *belief;
  const double in_mass = std::accumulate(b.begin(), b.begin() + n, 0.0);
  const double off = b[n];
  // The motion band; a step past either end of the route stays at the end.
  std::vector<float> moved(static_cast<size_t>(n), 0.0f);
  for (int i = 0; i < n; ++i) {
    if (b[i] == 0) continue;
    for (int d = -backward_; d <= forward_; ++d) {
      moved[std::clamp(i + d, 0, n - 1)] += b[i] * kernel_[d + backward_];
    }
  }
  const double jump_each = options_.jump * in_mass / n;
  const double enter_each = options_.enter * off / n;
  for (int j = 0; j < n; ++j) {
    b[j] = static_cast<float>((1 - options_.leave) * ((1 - options_.jump) * moved[j] + jump_each) +
                              enter_each);
  }
  b[n] = static_cast<float>(options_.leave * in_mass + (1 - options_.enter) * off);
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
  for (int l = 0; l <= n; ++l) {
    (*belief)[l] *= static_cast<float>(std::exp(gamma * (log_lik[l] - top)));
  }
  Normalise(belief);
}

SequenceAnswer SequenceFilter::Answer(const std::vector<float>& belief, uint32_t frames) const {
  const int n = num_locations_;
  SequenceAnswer a;
  a.location =
      static_cast<int>(std::max_element(belief.begin(), belief.begin() + n) - belief.begin());
  const int low = std::max(0, a.location - tolerance_);
  const int high = std::min(n - 1, a.location + tolerance_);
  a.probability = std::accumulate(belief.begin() + low, belief.begin() + high + 1, 0.0);
  a.off_map = belief[n];
  a.frames = frames;
  a.decision = a.probability >= options_.min_confidence ? Decision::kLocalised : Decision::kUnknown;
  return a;
}

SequenceAnswer SequenceFilter::Update(const FrameEvidence& evidence, SequenceState* state) const {
  const size_t size = static_cast<size_t>(num_locations_) + 1;
  if (state->belief.size() != size) {
    const double off = StationaryOffMap(options_);
    state->belief.assign(size, static_cast<float>((1 - off) / num_locations_));
    state->belief[num_locations_] = static_cast<float>(off);
    state->frames = 0;
  } else {
    Predict(&state->belief);
  }
  Observe(evidence, &state->belief);
  ++state->frames;
  return Answer(state->belief, state->frames);
}

}  // namespace sceneloc
