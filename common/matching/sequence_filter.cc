#include "common/matching/sequence_filter.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
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

// An update's working memory, kept by each thread from one update to the next: allocated
// afresh every frame, glibc hands large arrays back to the kernel and faults them in again,
// which once cost two thirds of a frame (docs/results.md, "Sessions: a lock per session").
struct Workspace {
  // Predict: the belief each location holds after the move, over every speed; the belief of
  // the locations that share their speeds (0 for those that move one by one); the shared
  // speeds after their change; the kernel of their steps, one value per whole step from
  // SequenceFilter::min_step_.
  std::vector<double> moved;
  std::vector<double> shared_loc;
  std::vector<double> shared_speeds;
  std::vector<double> kernel;
  // Predict: where the locations that move one by one land, per speed (num_speeds() values
  // a slot): slot_of[l] is location l's slot, -1 for none (always -1 between updates).
  std::vector<int32_t> slot_of;
  std::vector<uint32_t> slot_location;
  std::vector<double> slots;
  // Predict: the share of every (location, speed) that moves, and the belief every
  // (location, speed) holds whatever the move (the kidnap floor and the way back onto the
  // route); off-map after the prediction. fresh: every speed of every location alike.
  double moving = 1;
  double floor_each = 0;
  double off_map = 0;
  bool fresh = false;
  std::vector<float> scores;   // the frame's evidence read with the session's camera
  std::vector<float> blended;  // the scores with look-alikes blended (BlendLookAlikes)
  std::vector<double> log_lik;
  // EvidenceWeights: each location's weight, then off-map's.
  std::vector<double> weight;
  // Observe: the frame's single-frame posterior over the locations, exp((s_l - top) / T)
  // over posterior_total (empty: the frame has no evidence), which CheckTrack reads after it.
  std::vector<double> posterior;
  double posterior_total = 0;
  std::vector<double> weighed;      // Observe: the frame's weights off the tracked locations
  std::vector<double> change;       // ChangeSpeed's per-source speeds
  std::vector<double> correlation;  // Observe: the shared locations' weighted moves
  std::vector<double> ranked;       // Observe: the belief, partly sorted
  std::vector<uint32_t> order;
  std::vector<char> is_tracked;
};

Workspace& ThreadWorkspace() {
  thread_local Workspace workspace;
  return workspace;
}

// sum a[i] b[i] over n values, in four partial sums: one running sum is a chain of
// dependent additions the compiler may not reorder.
double Dot(const double* a, const double* b, int n) {
  double s[4] = {0, 0, 0, 0};
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    for (int k = 0; k < 4; ++k) s[k] += a[i + k] * b[i + k];
  }
  for (; i < n; ++i) s[0] += a[i] * b[i];
  return (s[0] + s[1]) + (s[2] + s[3]);
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
    : num_locations_(map.num_places()),
      tolerance_(map.options.tolerance),
      temperature_(options.evidence_temperature),
      options_(options),
      lookalike_offsets_(map.lookalike_offsets),
      lookalike_location_(map.lookalike_location),
      lookalike_ratio_(map.lookalike_ratio) {
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
        min_step_ = std::min(min_step_, whole + j);
        max_step_ = std::max(max_step_, whole + j);
      }
    }
  }
  reach_ = std::max(-min_step_, max_step_);
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

void SequenceFilter::ChangeSpeed(const float* row, double* out) const {
  const int speeds = num_speeds();
  const double change = options_.speed_change;
  std::fill(out, out + speeds, 0.0);
  double total = 0;
  // Kept with probability 1 - speed_change, else half a location per frame faster or
  // slower (at the fastest or the slowest, the one way there is).
  for (int v = 0; v < speeds; ++v) {
    const bool slower = v > 0, faster = v + 1 < speeds;
    const double each = (slower && faster) ? change / 2 : change;
    out[v] += ((slower || faster) ? 1 - change : 1) * row[v];
    if (slower) out[v - 1] += each * row[v];
    if (faster) out[v + 1] += each * row[v];
    total += row[v];
  }
  // And with probability speed_jump drawn afresh: the location's mass over every speed,
  // shared equally among them.
  if (const double redraw = options_.speed_jump; redraw > 0) {
    for (int v = 0; v < speeds; ++v) out[v] = (1 - redraw) * out[v] + redraw / speeds * total;
  }
}

void SequenceFilter::Predict(const SequenceState& state) const {
  Workspace& work = ThreadWorkspace();
  const int n = num_locations_, speeds = num_speeds();
  const double in_mass = std::accumulate(state.location.begin(), state.location.begin() + n, 0.0);
  const double off = state.location[n];
  // Of the belief on the route, 1 - leave stays on it and jump of that is carried anywhere
  // (the kidnap floor); enter of off-map comes back anywhere: any location, any speed.
  const double cells = static_cast<double>(speeds) * n;
  work.fresh = false;
  work.moving = (1 - options_.leave) * (1 - options_.jump);
  work.floor_each =
      (1 - options_.leave) * options_.jump * in_mass / cells + options_.enter * off / cells;
  work.off_map = options_.leave * in_mass + (1 - options_.enter) * off;

  // The locations that share their speeds: the shared speeds' change, and the kernel of
  // their steps (steps_: the speed's locations, give or take one).
  const float* shared_row = state.speeds.data() + state.tracked.size() * speeds;
  work.shared_speeds.resize(static_cast<size_t>(speeds));
  ChangeSpeed(shared_row, work.shared_speeds.data());
  work.kernel.assign(static_cast<size_t>(max_step_ - min_step_ + 1), 0.0);
  for (int v = 0; v < speeds; ++v) {
    for (const Step& step : steps_[v]) {
      work.kernel[step.locations - min_step_] += work.shared_speeds[v] * step.weight;
    }
  }
  work.shared_loc.assign(state.location.begin(), state.location.begin() + n);

  // The others one by one, each with its own speeds (or the shared ones): the tracked
  // locations, and those within a step of an end, where a step past the end turns the
  // robot round: it walks back the rest of the step at the opposite speed (ReflectAtEnds;
  // kept at the end instead, every step past it would pile up on the end location).
  if (work.slot_of.size() < static_cast<size_t>(n)) work.slot_of.resize(n, -1);
  work.slot_location.clear();
  work.slots.clear();
  work.change.resize(static_cast<size_t>(speeds));
  const auto slot = [&work, speeds](int at) {
    int32_t& s = work.slot_of[at];
    if (s < 0) {
      s = static_cast<int32_t>(work.slot_location.size());
      work.slot_location.push_back(static_cast<uint32_t>(at));
      work.slots.resize(work.slots.size() + speeds, 0.0);
    }
    return work.slots.data() + static_cast<size_t>(s) * speeds;
  };
  const int slowest = kSpeedsPerLocation * backward_, fastest = kSpeedsPerLocation * forward_;
  const auto move_alone = [&](int l, const float* row) {
    work.shared_loc[l] = 0;
    ChangeSpeed(row, work.change.data());
    for (int v = 0; v < speeds; ++v) {
      const int opposite = std::clamp(slowest - v, -slowest, fastest) + slowest;
      const double sped = state.location[l] * work.change[v];
      for (const Step& step : steps_[v]) {
        bool turned = false;
        const int at = ReflectAtEnds(l + step.locations, n, &turned);
        slot(at)[turned ? opposite : v] += step.weight * sped;
      }
    }
  };
  const int low_end = std::min(reach_, n), high_end = std::max(low_end, n - reach_);
  size_t next = 0;  // the first tracked location not below the one asked for
  const auto row_of = [&](int l) {
    while (next < state.tracked.size() && state.tracked[next] < static_cast<uint32_t>(l)) ++next;
    return next < state.tracked.size() && state.tracked[next] == static_cast<uint32_t>(l)
               ? state.speeds.data() + next * speeds
               : shared_row;
  };
  for (int l = 0; l < low_end; ++l) move_alone(l, row_of(l));
  for (; next < state.tracked.size() && state.tracked[next] < static_cast<uint32_t>(high_end);
       ++next) {
    const auto l = static_cast<int>(state.tracked[next]);
    if (l >= low_end) move_alone(l, state.speeds.data() + next * speeds);
  }
  for (int l = high_end; l < n; ++l) move_alone(l, row_of(l));

  // Each location's belief over every speed after the move: the shared locations' steps
  // (none of which leaves the route), then the others'.
  std::vector<double>& moved = work.moved;
  moved.assign(static_cast<size_t>(n), 0.0);
  for (int d = min_step_; d <= max_step_; ++d) {
    const double k = work.kernel[d - min_step_];
    if (k == 0) continue;
    const int first = std::max(0, -d), last = std::min(n, n - d);
    const double* from = work.shared_loc.data();
    double* to = moved.data();
    for (int l = first; l < last; ++l) to[l + d] += k * from[l];
  }
  for (size_t i = 0; i < work.slot_location.size(); ++i) {
    const double* s = work.slots.data() + i * speeds;
    moved[work.slot_location[i]] += std::accumulate(s, s + speeds, 0.0);
  }
  for (double& m : moved) m = work.moving * m + speeds * work.floor_each;
}

void SequenceFilter::PredictFresh() const {
  Workspace& work = ThreadWorkspace();
  const int n = num_locations_;
  const double off = StationaryOffMap(options_);
  work.fresh = true;
  work.moved.assign(static_cast<size_t>(n), (1 - off) / n);
  work.off_map = off;
  work.slot_location.clear();
  work.slots.clear();
}

void SequenceFilter::Spread(const std::vector<double>& posterior,
                            std::vector<double>* log_lik) const {
  const int n = num_locations_;
  std::vector<double>& ll = *log_lik;
  const double top = *std::max_element(ll.begin(), ll.begin() + n);
  // The likelihood over its best, exp(ll - top): the posterior, whose best is 1 too.
  const std::vector<double>& lik = posterior;
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

const std::vector<float>& SequenceFilter::BlendLookAlikes(const std::vector<float>& s) const {
  if (lookalike_offsets_.empty()) return s;
  std::vector<float>& blended = ThreadWorkspace().blended;
  blended = s;
  const int n = num_locations_;
  for (int l = 0; l < n; ++l) {
    const uint32_t begin = lookalike_offsets_[l], end = lookalike_offsets_[l + 1];
    const float share = 1.0f / static_cast<float>(1 + end - begin);
    for (uint32_t k = begin; k < end; ++k) {
      const float rho = std::min(lookalike_ratio_[k], static_cast<float>(kMaxLookAlikeRatio));
      blended[l] += rho * share * (s[lookalike_location_[k]] - s[l]);
    }
  }
  return blended;
}

void SequenceFilter::EvidenceWeights(const std::vector<float>& frame_scores, double in_map) const {
  Workspace& work = ThreadWorkspace();
  const int n = num_locations_;
  const bool sized = frame_scores.size() == static_cast<size_t>(n);
  const std::vector<float>& s = sized ? BlendLookAlikes(frame_scores) : frame_scores;
  const bool has_scores =
      s.size() == static_cast<size_t>(n) &&
      *std::max_element(s.begin(), s.end()) != *std::min_element(s.begin(), s.end());
  std::vector<double>& posterior = work.posterior;
  posterior.clear();
  std::vector<double>& weight = work.weight;
  if (!has_scores && in_map < 0) {  // nothing observed: prediction only
    weight.assign(static_cast<size_t>(n) + 1, 1.0);
    return;
  }
  const double p_in = in_map < 0 ? 0.5 : std::clamp(in_map, 1e-4, 1 - 1e-4);
  const double gamma = options_.evidence_weight;
  // log P(frame | l) up to a constant shared by every state: the single-frame posterior
  // over a uniform prior (even odds of in-map, 1/N per location) is a likelihood ratio.
  // The frame says nothing about the robot's speed: every speed gets the same.
  std::vector<double>& log_lik = work.log_lik;
  log_lik.assign(static_cast<size_t>(n) + 1, std::log(p_in));
  if (has_scores) {
    const float top = *std::max_element(s.begin(), s.end());
    posterior.resize(static_cast<size_t>(n));
    double z = 0;
    for (int l = 0; l < n; ++l) z += posterior[l] = std::exp((s[l] - top) / temperature_);
    work.posterior_total = z;
    const double offset = std::log(p_in) + std::log(static_cast<double>(n)) - std::log(z);
    for (int l = 0; l < n; ++l) log_lik[l] = (s[l] - top) / temperature_ + offset;
    if (!spread_.empty()) Spread(posterior, &log_lik);
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
  weight.resize(static_cast<size_t>(n) + 1);
  for (int l = 0; l <= n; ++l) weight[l] = std::exp(gamma * (log_lik[l] - top));
}

void SequenceFilter::Observe(const std::vector<float>& scores, double in_map,
                             SequenceState* state) const {
  EvidenceWeights(scores, in_map);
  Workspace& work = ThreadWorkspace();
  const int n = num_locations_, speeds = num_speeds();
  const std::vector<double>& weight = work.weight;
  // Every location's belief over every speed, weighed by the frame, normalised.
  std::vector<double>& at = work.moved;
  double off = weight[n] * work.off_map;
  double total = off;
  for (int l = 0; l < n; ++l) total += at[l] *= weight[l];
  if (!(total > 0) || !std::isfinite(total)) {  // cannot happen with finite evidence
    at.assign(static_cast<size_t>(n), 1.0);
    off = 1.0 / speeds;
    total = n + off;
    work.fresh = true;
  }
  state->location.resize(static_cast<size_t>(n) + 1);
  for (int l = 0; l < n; ++l) state->location[l] = static_cast<float>(at[l] / total);
  state->location[n] = static_cast<float>(off / total);

  // The most probable locations keep their speeds; ties go to the lower location, so
  // every process compacts a belief the same way.
  std::vector<uint32_t>& order = work.order;
  order.clear();
  if (tracked_ >= n) {
    order.resize(static_cast<size_t>(n));
    std::iota(order.begin(), order.end(), 0u);
  } else if (tracked_ > 0) {
    // The tracked_-th most probable belief, then every location above it and, in location
    // order, as many as are needed of those at it.
    std::vector<double>& ranked = work.ranked;
    ranked.assign(at.begin(), at.end());
    std::nth_element(ranked.begin(), ranked.begin() + (tracked_ - 1), ranked.end(),
                     std::greater<>());
    const double least = ranked[tracked_ - 1];
    int above = 0;
    for (int l = 0; l < n; ++l) above += at[l] > least ? 1 : 0;
    int at_least = tracked_ - above;
    for (int l = 0; l < n; ++l) {
      if (at[l] > least || (at[l] == least && at_least-- > 0))
        order.push_back(static_cast<uint32_t>(l));
    }
  }
  state->tracked.assign(order.begin(), order.end());
  state->speeds.assign((state->tracked.size() + 1) * speeds, 0.0f);
  // A row of speeds normalised; uniform where it holds none.
  const auto normalise_row = [speeds](const double* values, float* row) {
    const double sum = std::accumulate(values, values + speeds, 0.0);
    for (int v = 0; v < speeds; ++v) {
      row[v] = sum > 0 ? static_cast<float>(values[v] / sum) : 1.0f / static_cast<float>(speeds);
    }
  };
  std::vector<double>& values = work.change;
  values.resize(static_cast<size_t>(speeds));
  std::vector<char>& is_tracked = work.is_tracked;
  is_tracked.assign(static_cast<size_t>(n), 0);
  const std::vector<double>& shared_loc = work.shared_loc;
  for (size_t i = 0; i < state->tracked.size(); ++i) {
    const uint32_t l = state->tracked[i];
    is_tracked[l] = 1;
    if (work.fresh) {
      std::fill(values.begin(), values.end(), 1.0);
    } else {
      // The location's speeds as the move left them (the frame weighs them all alike).
      const int32_t s = work.slot_of[l];
      for (int v = 0; v < speeds; ++v) {
        double m = 0;
        for (const Step& step : steps_[v]) {
          const int from = static_cast<int>(l) - step.locations;
          if (from >= 0 && from < n) m += step.weight * shared_loc[from];
        }
        m *= work.shared_speeds[v];
        if (s >= 0) m += work.slots[static_cast<size_t>(s) * speeds + v];
        values[v] = work.moving * m + work.floor_each;
      }
    }
    normalise_row(values.data(), state->speeds.data() + i * speeds);
  }
  // The others share the speeds of their mass together: the shared locations' moves onto
  // them (a correlation of their belief with the frame's weights there), the others'
  // moves, and the floor.
  float* shared = state->speeds.data() + state->tracked.size() * speeds;
  if (work.fresh) {
    std::fill(values.begin(), values.end(), 1.0);
  } else {
    std::vector<double>& weighed = work.weighed;
    weighed.resize(static_cast<size_t>(n));
    double weighed_total = 0;
    for (int l = 0; l < n; ++l) weighed_total += weighed[l] = is_tracked[l] ? 0.0 : weight[l];
    std::vector<double>& correlation = work.correlation;
    correlation.assign(work.kernel.size(), 0.0);
    for (int d = min_step_; d <= max_step_; ++d) {
      if (work.kernel[d - min_step_] == 0) continue;
      const int first = std::max(0, -d), last = std::min(n, n - d);
      correlation[d - min_step_] =
          Dot(weighed.data() + first + d, shared_loc.data() + first, std::max(0, last - first));
    }
    for (int v = 0; v < speeds; ++v) {
      double m = 0;
      for (const Step& step : steps_[v]) m += step.weight * correlation[step.locations - min_step_];
      values[v] = work.shared_speeds[v] * m;
    }
    for (size_t i = 0; i < work.slot_location.size(); ++i) {
      const double w = weighed[work.slot_location[i]];
      const double* s = work.slots.data() + i * speeds;
      for (int v = 0; v < speeds; ++v) values[v] += w * s[v];
    }
    for (int v = 0; v < speeds; ++v) {
      values[v] = work.moving * values[v] + work.floor_each * weighed_total;
    }
  }
  normalise_row(values.data(), shared);
  for (uint32_t l : work.slot_location) work.slot_of[l] = -1;
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
  if (!Fits(*state)) {
    PredictFresh();
    state->frames = 0;
    state->camera_counts.clear();
    state->support = SequenceState::kFreshSupport;
  } else {
    Predict(*state);
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
  Observe(*scores, evidence.in_map, state);
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
