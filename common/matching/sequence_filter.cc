#include "common/matching/sequence_filter.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

#include "common/matching/confidence.h"
#include "common/matching/evidence.h"

namespace sceneloc {
namespace {

// The least likelihood ratio a frame gives the session's track in SequenceFilter::
// CheckTrack: a frame that places the robot nowhere near the track (a confident look-alike)
// counts as at worst a fifth as likely under "supported" as under "says nothing", so one
// such frame lowers the support by a bounded factor whatever the map's size.
constexpr double kLeastRatio = 0.2;

// The stationary share of off-map of the enter/leave chain: where a fresh session starts.
double StationaryOffMap(const SequenceOptions& o) {
  return o.leave + o.enter > 0 ? o.leave / (o.leave + o.enter) : 0;
}

// An update's working memory, kept by each thread from one update to the next. At 10,000
// locations and 17 speeds the full belief and the prediction's two copies are 680 KB each:
// allocated afresh every frame, glibc hands them back to the kernel and faults them in
// again, which cost two thirds of a frame's 6 ms on the 2-core VM (docs/results.md,
// "Sessions: a lock per session"). Reused, a frame costs 2.1 ms and the answers are the same.
struct Workspace {
  std::vector<float> belief;  // the full belief for this frame (Expand)
  std::vector<float> scores;  // the frame's evidence read with the session's camera
  std::vector<float> sped;    // Predict: after the change of speed
  std::vector<float> moved;   // Predict: after the step
  std::vector<float> total;   // Predict: each location over every speed (speed_jump)
  std::vector<double> log_lik;
  // Observe: the frame's single-frame posterior over the locations, exp((s_l - top) / T)
  // over posterior_total (empty: the frame has no evidence), which CheckTrack reads after it.
  std::vector<double> posterior;
  double posterior_total = 0;
  std::vector<double> lik;  // Spread
  std::vector<double> at;   // Compact: every speed together
  std::vector<uint32_t> order;
  std::vector<char> is_tracked;
};

Workspace& ThreadWorkspace() {
  thread_local Workspace workspace;
  return workspace;
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

FrameEvidence EvidenceOf(const LocaliseResult& result, const Map& map,
                         const MatchOptions& options) {
  FrameEvidence e;
  e.location_scores = result.location_scores;
  e.candidates = result.candidates;
  e.fusion = options;
  e.fusion.camera_log_scale = result.camera_log_scale;
  e.fusion.camera_log_doubt = result.camera_log_doubt;
  e.fusion.camera_known = true;
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
      temperature_(options.evidence_temperature),
      options_(options) {
  const int band = MotionBand(map);
  forward_ = options.max_forward >= 0 ? options.max_forward : 2 * band;
  backward_ = options.max_backward >= 0 ? options.max_backward : 2 * band;
  tracked_ = std::min(options.tracked_locations, num_locations_);
  if (options.evidence_spread > 0) {
    spread_.push_back(1.0);
    for (int d = 1; d <= band; ++d) spread_.push_back(spread_.back() * options.evidence_spread);
  }
  // Each speed's step: its locations split between the two whole steps around it (1.5:
  // half 1, half 2), each give or take one location (1/6, 4/6, 1/6).
  constexpr double kJitter[3] = {1.0 / 6, 4.0 / 6, 1.0 / 6};
  steps_.resize(static_cast<size_t>(num_speeds()));
  for (int v = 0; v < num_speeds(); ++v) {
    const int halves = v - kSpeedsPerLocation * backward_;           // speed in half locations
    const int low = halves >= 0 ? halves / 2 : -((1 - halves) / 2);  // floor(halves / 2)
    const bool half = halves - 2 * low != 0;
    for (const auto& [whole, share] :
         {std::pair<int, double>{low, half ? 0.5 : 1.0}, {low + 1, half ? 0.5 : 0.0}}) {
      if (share == 0) continue;
      for (int j = -1; j <= 1; ++j) {
        steps_[v].push_back({whole + j, static_cast<float>(share * kJitter[j + 1])});
      }
    }
  }
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
  const int speeds = num_speeds();
  std::vector<float>& b = *belief;
  const size_t in_size = static_cast<size_t>(speeds) * n;
  const double in_mass = std::accumulate(b.begin(), b.begin() + in_size, 0.0);
  const double off = b[in_size];
  // The speed first: kept with probability 1 - speed_change, else half a location per frame
  // faster or slower (at the fastest or the slowest, the one way there is).
  const double change = options_.speed_change;
  std::vector<float>& sped = ThreadWorkspace().sped;
  sped.assign(in_size, 0.0f);
  for (int v = 0; v < speeds; ++v) {
    const bool slower = v > 0, faster = v + 1 < speeds;
    const double each = (slower && faster) ? change / 2 : change;
    const float* from = b.data() + static_cast<size_t>(v) * n;
    float* stay = sped.data() + static_cast<size_t>(v) * n;
    float* down = slower ? sped.data() + static_cast<size_t>(v - 1) * n : nullptr;
    float* up = faster ? sped.data() + static_cast<size_t>(v + 1) * n : nullptr;
    const double keep = (slower || faster) ? 1 - change : 1;
    for (int l = 0; l < n; ++l) {
      stay[l] += static_cast<float>(keep * from[l]);
      if (down != nullptr) down[l] += static_cast<float>(each * from[l]);
      if (up != nullptr) up[l] += static_cast<float>(each * from[l]);
    }
  }
  // And with probability speed_jump the speed is drawn afresh: each location's mass over
  // every speed, shared equally among them.
  if (const double redraw = options_.speed_jump; redraw > 0) {
    std::vector<float>& total = ThreadWorkspace().total;
    total.assign(static_cast<size_t>(n), 0.0f);
    for (int v = 0; v < speeds; ++v) {
      const float* from = b.data() + static_cast<size_t>(v) * n;
      for (int l = 0; l < n; ++l) total[l] += from[l];
    }
    const auto keep = static_cast<float>(1 - redraw), each = static_cast<float>(redraw / speeds);
    for (int v = 0; v < speeds; ++v) {
      float* to = sped.data() + static_cast<size_t>(v) * n;
      for (int l = 0; l < n; ++l) to[l] = keep * to[l] + each * total[l];
    }
  }
  // Then the step (steps_: the speed's locations, give or take one). A step
  // past either end of the route turns the robot round there: it walks back the rest of
  // the step at the opposite speed (ReflectAtEnds; kept at the end instead, every step past
  // it would pile up on the end location).
  std::vector<float>& moved = ThreadWorkspace().moved;
  moved.assign(in_size, 0.0f);
  const int slowest = kSpeedsPerLocation * backward_, fastest = kSpeedsPerLocation * forward_;
  for (int v = 0; v < speeds; ++v) {
    const int opposite = std::clamp(slowest - v, -slowest, fastest) + slowest;
    const float* from = sped.data() + static_cast<size_t>(v) * n;
    float* to = moved.data() + static_cast<size_t>(v) * n;
    for (const Step& step : steps_[v]) {
      // Sources whose step stays on the route: one contiguous, vectorisable run.
      const int first = std::clamp(-step.locations, 0, n),
                last = std::clamp(n - step.locations, 0, n);
      for (int l = first; l < last; ++l) to[l + step.locations] += step.weight * from[l];
      // The rest step past an end and turn round there.
      const auto turn_round = [&](int l) {
        bool turned = false;
        const int at = ReflectAtEnds(l + step.locations, n, &turned);
        moved[static_cast<size_t>(turned ? opposite : v) * n + at] += step.weight * from[l];
      };
      for (int l = 0; l < first; ++l) turn_round(l);
      for (int l = std::max(last, first); l < n; ++l) turn_round(l);
    }
  }
  // The kidnap floor and the way back onto the route: any location, any speed.
  const double jump_each = options_.jump * in_mass / static_cast<double>(in_size);
  const double enter_each = options_.enter * off / static_cast<double>(in_size);
  for (size_t i = 0; i < in_size; ++i) {
    b[i] = static_cast<float>((1 - options_.leave) * ((1 - options_.jump) * moved[i] + jump_each) +
                              enter_each);
  }
  b[in_size] = static_cast<float>(options_.leave * in_mass + (1 - options_.enter) * off);
}

void SequenceFilter::Spread(std::vector<double>* log_lik) const {
  const int n = num_locations_;
  std::vector<double>& ll = *log_lik;
  const double top = *std::max_element(ll.begin(), ll.begin() + n);
  std::vector<double>& lik = ThreadWorkspace().lik;
  lik.resize(static_cast<size_t>(n));
  for (int l = 0; l < n; ++l) lik[l] = std::exp(ll[l] - top);  // <= 1, the best 1
  const int radius = static_cast<int>(spread_.size()) - 1;
  for (int l = 0; l < n; ++l) {
    double sum = lik[l];
    for (int d = 1; d <= radius; ++d) {
      if (l - d >= 0) sum += spread_[d] * lik[l - d];
      if (l + d < n) sum += spread_[d] * lik[l + d];
    }
    ll[l] = std::log(sum) + top;  // sum >= lik[l] > 0 unless it underflowed: log(0) = -inf
  }
}

void SequenceFilter::Observe(const std::vector<float>& s, double in_map,
                             std::vector<float>* belief) const {
  const int n = num_locations_;
  const bool has_scores =
      s.size() == static_cast<size_t>(n) &&
      *std::max_element(s.begin(), s.end()) != *std::min_element(s.begin(), s.end());
  std::vector<double>& posterior = ThreadWorkspace().posterior;
  posterior.clear();
  if (!has_scores && in_map < 0) return;  // nothing observed: prediction only
  const double p_in = in_map < 0 ? 0.5 : std::clamp(in_map, 1e-4, 1 - 1e-4);
  const double gamma = options_.evidence_weight;
  // log P(frame | l) up to a constant shared by every state: the single-frame posterior
  // over a uniform prior (even odds of in-map, 1/N per location) is a likelihood ratio.
  // The frame says nothing about the robot's speed: every speed gets the same.
  std::vector<double>& log_lik = ThreadWorkspace().log_lik;
  log_lik.assign(static_cast<size_t>(n) + 1, std::log(p_in));
  if (has_scores) {
    const float top = *std::max_element(s.begin(), s.end());
    posterior.resize(static_cast<size_t>(n));
    double z = 0;
    for (int l = 0; l < n; ++l) z += posterior[l] = std::exp((s[l] - top) / temperature_);
    ThreadWorkspace().posterior_total = z;
    const double offset = std::log(p_in) + std::log(static_cast<double>(n)) - std::log(z);
    for (int l = 0; l < n; ++l) log_lik[l] = (s[l] - top) / temperature_ + offset;
    if (!spread_.empty()) Spread(&log_lik);
    const double floor = options_.evidence_floor;
    if (floor > 0) {  // log((1 - floor) L + floor p_in), without overflow: log-sum-exp
      const double a = std::log(1 - floor), b = std::log(floor * p_in);
      for (int l = 0; l < n; ++l) {
        const double x = a + log_lik[l], hi = std::max(x, b);
        log_lik[l] = hi + std::log(std::exp(x - hi) + std::exp(b - hi));
      }
    }
  }
  log_lik[n] = std::log(1 - p_in);
  const double top = *std::max_element(log_lik.begin(), log_lik.end());
  std::vector<float>& b = *belief;
  const int speeds = num_speeds();
  for (int l = 0; l < n; ++l) {
    const auto w = static_cast<float>(std::exp(gamma * (log_lik[l] - top)));
    for (int v = 0; v < speeds; ++v) b[static_cast<size_t>(v) * n + l] *= w;
  }
  b[static_cast<size_t>(speeds) * n] *= static_cast<float>(std::exp(gamma * (log_lik[n] - top)));
  Normalise(belief);
}

bool SequenceFilter::Fits(const SequenceState& state) const {
  const size_t n = static_cast<size_t>(num_locations_), tracked = state.tracked.size();
  if (state.location.size() != n + 1 || tracked > n ||
      !(state.support >= 0 && state.support <= 1) ||
      (!state.camera_counts.empty() &&
       state.camera_counts.size() != static_cast<size_t>(SequenceOptions::kCameraBins)) ||
      state.speeds.size() != (tracked + 1) * static_cast<size_t>(num_speeds())) {
    return false;
  }
  for (size_t i = 0; i < tracked; ++i) {
    if (state.tracked[i] >= n || (i > 0 && state.tracked[i] <= state.tracked[i - 1])) return false;
  }
  return true;
}

void SequenceFilter::Expand(const SequenceState& state, std::vector<float>* belief) const {
  const int n = num_locations_, speeds = num_speeds();
  belief->resize(static_cast<size_t>(speeds) * n + 1);
  const float* shared = state.speeds.data() + state.tracked.size() * speeds;
  size_t next = 0;  // the next tracked location's index in state.tracked
  for (int l = 0; l < n; ++l) {
    const bool tracked =
        next < state.tracked.size() && state.tracked[next] == static_cast<uint32_t>(l);
    const float* row = tracked ? state.speeds.data() + (next++) * speeds : shared;
    for (int v = 0; v < speeds; ++v)
      (*belief)[static_cast<size_t>(v) * n + l] = state.location[l] * row[v];
  }
  belief->back() = state.location[n];
}

void SequenceFilter::Compact(const std::vector<float>& belief, SequenceState* state) const {
  const int n = num_locations_, speeds = num_speeds();
  std::vector<double>& at = ThreadWorkspace().at;  // every speed together
  at.assign(static_cast<size_t>(n), 0.0);
  for (int v = 0; v < speeds; ++v) {
    for (int l = 0; l < n; ++l) at[l] += belief[static_cast<size_t>(v) * n + l];
  }
  state->location.resize(static_cast<size_t>(n) + 1);
  for (int l = 0; l < n; ++l) state->location[l] = static_cast<float>(at[l]);
  state->location[n] = belief.back();
  // The most probable locations keep their speeds; ties go to the lower location, so
  // every process compacts a belief the same way.
  std::vector<uint32_t>& order = ThreadWorkspace().order;
  order.resize(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0u);
  const auto more_probable = [&at](uint32_t a, uint32_t b) {
    return at[a] > at[b] || (at[a] == at[b] && a < b);
  };
  if (tracked_ < n) {
    std::nth_element(order.begin(), order.begin() + tracked_, order.end(), more_probable);
    order.resize(static_cast<size_t>(tracked_));
    std::sort(order.begin(), order.end());
  }
  state->tracked.assign(order.begin(), order.end());  // not order's capacity of n
  state->speeds.assign((state->tracked.size() + 1) * speeds, 0.0f);
  // A row of speeds from a location's column of the belief; uniform where it holds none.
  const auto normalise_row = [speeds](float* row, double total) {
    for (int v = 0; v < speeds; ++v) {
      row[v] = total > 0 ? static_cast<float>(row[v] / total) : 1.0f / static_cast<float>(speeds);
    }
  };
  std::vector<char>& is_tracked = ThreadWorkspace().is_tracked;
  is_tracked.assign(static_cast<size_t>(n), 0);
  for (size_t i = 0; i < state->tracked.size(); ++i) {
    const uint32_t l = state->tracked[i];
    is_tracked[l] = 1;
    float* row = state->speeds.data() + i * speeds;
    for (int v = 0; v < speeds; ++v) row[v] = belief[static_cast<size_t>(v) * n + l];
    normalise_row(row, at[l]);
  }
  // The others share the speeds of their mass together.
  float* shared = state->speeds.data() + state->tracked.size() * speeds;
  double rest = 0;
  for (int v = 0; v < speeds; ++v) {
    double sum = 0;
    for (int l = 0; l < n; ++l) {
      if (is_tracked[l] == 0) sum += belief[static_cast<size_t>(v) * n + l];
    }
    shared[v] = static_cast<float>(sum);
    rest += sum;
  }
  normalise_row(shared, rest);
}

SequenceAnswer SequenceFilter::Answer(const SequenceState& state) const {
  const int n = num_locations_;
  const std::vector<float>& at = state.location;
  SequenceAnswer a;
  const auto window = [&](int l) {
    const int low = std::max(0, l - tolerance_), high = std::min(n - 1, l + tolerance_);
    return std::accumulate(at.begin() + low, at.begin() + high + 1, 0.0);
  };
  if (options_.answer_window) {
    // The belief within the tolerance of each location, slid along the route: the first
    // location with the most (ties, to within the sliding sum's rounding: the lower).
    constexpr double kTie = 1e-9;
    double inside = window(0), most = -1;
    for (int l = 0; l < n; ++l) {
      if (l > 0) {
        if (l + tolerance_ < n) inside += at[l + tolerance_];
        if (l - tolerance_ - 1 >= 0) inside -= at[l - tolerance_ - 1];
      }
      if (inside > most + kTie) {
        most = inside;
        a.location = l;
      }
    }
  } else {
    a.location = static_cast<int>(std::max_element(at.begin(), at.begin() + n) - at.begin());
  }
  // Summed afresh: the sliding sum's rounding must not reach the reported probability.
  a.belief = window(a.location);
  a.probability = a.belief;
  a.support = state.support;
  a.off_map = at[n];
  a.frames = state.frames;
  return a;
}

void SequenceFilter::CheckTrack(double in_map, SequenceAnswer* answer, SequenceState* state) const {
  if (options_.support_weight > 0) {
    const int n = num_locations_, a = answer->location;
    // The frame's posterior as Observe read it: the mass within `reach` of the answer.
    const Workspace& work = ThreadWorkspace();
    const std::vector<double>& posterior = work.posterior;
    const auto near = [&](int reach) {
      const int low = std::max(0, a - reach), high = std::min(n - 1, a + reach);
      return std::accumulate(posterior.begin() + low, posterior.begin() + high + 1, 0.0) /
             work.posterior_total;
    };
    const double h = options_.support_switch;
    const double prior = state->support * (1 - h) + (1 - state->support) * h;
    double ratio = 1;  // a frame without evidence says nothing about the track
    double own = 0;    // the frame's own P(within the tolerance of the answer), at most the belief
    if (!posterior.empty()) {
      // The frame's posterior within a frame's travel of the answer, over the share of the
      // locations there: a likelihood ratio against a frame that says nothing.
      const int reach = std::max(forward_, backward_);
      const int inside = std::min(n - 1, a + reach) - std::max(0, a - reach) + 1;
      ratio = std::pow(std::max(near(reach) * n / inside, kLeastRatio), options_.support_weight);
      // Never above the belief: a frame agreeing with an answer the belief doubts (a
      // look-alike the session has drifted onto) must not make it surer.
      own = std::min(answer->belief, near(tolerance_) * (in_map < 0 ? 1.0 : in_map));
    }
    const double supported = prior * ratio;
    state->support = static_cast<float>(supported / (supported + 1 - prior));
    answer->support = state->support;
    answer->probability = state->support * answer->belief + (1 - state->support) * own;
  }
  answer->decision =
      answer->probability >= options_.min_confidence ? Decision::kLocalised : Decision::kUnknown;
}

double SequenceFilter::CameraLogScale(const SequenceState& state, double unlearnt) const {
  if (!options_.learn_camera_scale || state.camera_counts.size() != SequenceOptions::kCameraBins) {
    return unlearnt;
  }
  const double total = std::accumulate(state.camera_counts.begin(), state.camera_counts.end(), 0.0);
  if (total < options_.camera_min_frames) return unlearnt;
  // The median, spread evenly over its bin.
  double below = 0;
  for (int i = 0; i < SequenceOptions::kCameraBins; ++i) {
    const double count = state.camera_counts[i];
    if (below + count >= total / 2 && count > 0) {
      return -SequenceOptions::kCameraRange +
             SequenceOptions::kCameraBinWidth * (i + (total / 2 - below) / count);
    }
    below += count;
  }
  return unlearnt;
}

void SequenceFilter::MeasureCamera(const FrameEvidence& evidence, const SequenceAnswer& answer,
                                   SequenceState* state) const {
  if (!options_.learn_camera_scale || answer.decision != Decision::kLocalised) return;
  // The verified candidates within the tolerance of the answer, above chance. Their log
  // scales run from the frames behind the robot (things looked smaller from there: m > 0)
  // to those ahead (m < 0) around the camera's own at the robot's place; weighted by inliers
  // their median is it. The raw inlier counts weigh, not the scale-weighted ones: a
  // measurement that the current estimate chose would only confirm it (a single best match
  // is more often the frame behind, and its measurement fed back made answers lag).
  struct Measured {
    float log_scale;
    int inliers;
  };
  std::vector<Measured> near;
  double total = 0;
  int most = 0;
  for (const CandidateEvidence& c : evidence.candidates) {
    if (std::abs(c.location - answer.location) > tolerance_ ||
        c.inliers < evidence.fusion.verify_chance_inliers || c.inliers <= 0 ||
        !std::isfinite(c.log_scale)) {
      continue;
    }
    near.push_back({c.log_scale, c.inliers});
    total += c.inliers;
    most = std::max(most, c.inliers);
  }
  if (most < options_.camera_min_inliers) return;  // no clear match: nothing measured
  std::sort(near.begin(), near.end(),
            [](const Measured& a, const Measured& b) { return a.log_scale < b.log_scale; });
  double below = 0, measured = near.front().log_scale;
  for (const Measured& m : near) {
    below += m.inliers;
    if (below >= total / 2) {
      measured = m.log_scale;
      break;
    }
  }
  std::vector<uint16_t>& counts = state->camera_counts;
  counts.resize(SequenceOptions::kCameraBins, 0);
  const double range = SequenceOptions::kCameraRange;
  const int bin =
      std::min(static_cast<int>(std::floor((std::clamp(measured, -range, range) + range) /
                                           SequenceOptions::kCameraBinWidth)),
               SequenceOptions::kCameraBins - 1);
  if (counts[bin] == UINT16_MAX) {  // halve them all: the median stays, the newest count more
    for (uint16_t& c : counts) c = static_cast<uint16_t>(c / 2);
  }
  ++counts[bin];
}

SequenceAnswer SequenceFilter::Update(const FrameEvidence& evidence, SequenceState* state) const {
  Workspace& work = ThreadWorkspace();
  std::vector<float>& belief = work.belief;
  if (!Fits(*state)) {
    const double off = StationaryOffMap(options_);
    const size_t size = static_cast<size_t>(num_speeds()) * num_locations_ + 1;
    belief.assign(size, static_cast<float>((1 - off) / static_cast<double>(size - 1)));
    belief.back() = static_cast<float>(off);
    state->frames = 0;
    state->camera_counts.clear();
    state->support = SequenceState::kFreshSupport;
  } else {
    Expand(*state, &belief);
    Predict(&belief);
  }
  // The frame's evidence read with the session's camera (or the one its client states):
  // only the verified candidates' scores depend on it.
  const double framed = evidence.fusion.camera_log_scale;
  const double camera = evidence.camera_log_scale.value_or(CameraLogScale(*state, framed));
  const std::vector<float>* scores = &evidence.location_scores;
  if (camera != evidence.fusion.camera_log_scale && !evidence.candidates.empty()) {
    work.scores = evidence.location_scores;
    MatchOptions fusion = evidence.fusion;
    fusion.camera_log_scale = camera;
    ScoreCandidates(evidence.candidates, fusion, &work.scores);
    scores = &work.scores;
  }
  Observe(*scores, evidence.in_map, &belief);
  Compact(belief, state);
  if (state->frames < UINT32_MAX) ++state->frames;  // a carried count can be anything
  SequenceAnswer answer = Answer(*state);
  CheckTrack(evidence.in_map, &answer, state);
  answer.camera_log_scale = camera;
  MeasureCamera(evidence, answer, state);
  answer.measured_camera_log_scale =
      CameraLogScale(*state, evidence.camera_log_scale.has_value() ? 0.0 : framed);
  return answer;
}

}  // namespace sceneloc
