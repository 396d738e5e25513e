// What a session costs per frame (common/matching/sequence_filter.h), against the number of
// tour locations: the filter's Update on single-frame evidence of a walking robot, at 200
// locations (the Gardens Point map) up to 10,000, with the fitted complexity. Also the
// session store's memory for 1,000 live sessions of each size, and its throughput with one
// and two threads updating their own sessions (frames of different sessions run in
// parallel: compare items_per_second of threads:2 with threads:1).
//
//   sequence_filter_benchmark [benchmark flags]
//   e.g. --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// The maps are generated in code: the filter reads only the number of locations, the
// tolerance and the landmarks' track lengths (its motion band), not descriptors.
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <random>

#include "common/matching/sequence_filter.h"
#include "server/session_store.h"
#include "server/session_token.h"

namespace sceneloc {
namespace {

// A map of `locations` tour images whose landmarks are each seen in 3 images (band 3).
Map MakeMap(int locations) {
  Map map;
  for (int i = 0; i < locations; ++i) map.image_names.push_back(std::to_string(i));
  const int landmarks = locations * 10;
  map.observation_offsets.resize(static_cast<size_t>(landmarks) + 1);
  for (int g = 0; g <= landmarks; ++g) map.observation_offsets[g] = 3 * g;
  return map;
}

// Evidence of a frame at `where`: a peak with its neighbours, noise elsewhere.
FrameEvidence Frame(int locations, int where, std::mt19937* rng) {
  std::normal_distribution<float> noise(0, 0.4f);
  FrameEvidence e;
  e.in_map = 0.95;
  e.location_scores.resize(locations);
  for (int l = 0; l < locations; ++l) {
    const double d = l - where;
    e.location_scores[l] = static_cast<float>(4 * std::exp(-d * d / 2)) + noise(*rng);
  }
  return e;
}

// One frame of a session on a map of range(0) locations, with `options`.
void RunFilterUpdate(benchmark::State& state, const SequenceOptions& options) {
  const int n = static_cast<int>(state.range(0));
  const Map map = MakeMap(n);
  const SequenceFilter filter(map, options);
  std::mt19937 rng(1);
  std::vector<FrameEvidence> frames;
  for (int t = 0; t < 64; ++t) frames.push_back(Frame(n, (t * n) / 64, &rng));
  SequenceState session;
  size_t t = 0;
  for (auto _ : state) {
    SequenceAnswer a = filter.Update(frames[t++ % frames.size()], &session);
    benchmark::DoNotOptimize(a);
  }
  state.SetComplexityN(n);
  state.counters["state_bytes"] = static_cast<double>(session.MemoryBytes());
  state.counters["token_bytes"] = static_cast<double>(
      SerializeSessionToken(session, {"key", "robot", 0, n, filter.num_speeds()}).size());
}
void BM_FilterUpdate(benchmark::State& state) { RunFilterUpdate(state, SequenceOptions{}); }
BENCHMARK(BM_FilterUpdate)
    ->Arg(200)
    ->Arg(1000)
    ->Arg(3000)
    ->Arg(10000)
    ->Arg(20000)
    ->Complexity(benchmark::oN);

// The same without the check of the track (sequence.support_weight 0: the probability is the
// belief alone): the difference is what SequenceFilter::CheckTrack costs.
void BM_FilterUpdateBeliefOnly(benchmark::State& state) {
  SequenceOptions options;
  options.support_weight = 0;
  RunFilterUpdate(state, options);
}
BENCHMARK(BM_FilterUpdateBeliefOnly)->Arg(200)->Arg(10000);

// The same without the speed drawn afresh (sequence.speed_jump 0): the difference is what
// the heavy tail on the speed's change costs in SequenceFilter::Predict.
void BM_FilterUpdateNoSpeedJump(benchmark::State& state) {
  SequenceOptions options;
  options.speed_jump = 0;
  RunFilterUpdate(state, options);
}
BENCHMARK(BM_FilterUpdateNoSpeedJump)->Arg(200)->Arg(10000);

// 1,000 live sessions in the server's store, each after one frame: the memory they hold.
void BM_ThousandSessions(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const Map map = MakeMap(n);
  const SequenceFilter filter(map, SequenceOptions{});
  std::mt19937 rng(2);
  const FrameEvidence frame = Frame(n, n / 2, &rng);
  SessionCounts counts;
  for (auto _ : state) {
    SessionStore store(SessionOptions{});
    for (int s = 0; s < 1000; ++s) {
      store.Update("robot-key", "map", "robot-" + std::to_string(s), 1, {},
                   SessionStore::Clock::now(),
                   [&](SequenceState* st) { filter.Update(frame, st); });
    }
    counts = store.Counts();
  }
  state.counters["sessions"] = static_cast<double>(counts.live);
  state.counters["memory_MB"] = static_cast<double>(counts.memory_bytes) / 1e6;
  state.counters["bytes_per_session"] = static_cast<double>(counts.memory_bytes) / counts.live;
}
BENCHMARK(BM_ThousandSessions)->Arg(200)->Arg(10000)->Unit(benchmark::kMillisecond);

// One store shared by the benchmark's threads, each updating its own session with the real
// filter: frames per second through SessionStore::Update. The robot walks a location a
// frame over 256 frames and starts again (BM_FilterUpdate's evidence jumps n/64 locations a
// frame, a kidnap each frame at 10,000 locations, which costs more).
struct StoreFixture {
  explicit StoreFixture(int n) : map(MakeMap(n)), filter(map, SequenceOptions{}) {
    std::mt19937 rng(3);
    for (int t = 0; t < 256; ++t) frames.push_back(Frame(n, (n / 4 + t) % n, &rng));
  }
  Map map;
  SequenceFilter filter;
  SessionStore store{SessionOptions{}};
  std::vector<FrameEvidence> frames;
};

StoreFixture& SharedStore(int n) {
  static std::mutex mutex;
  static std::map<int, std::unique_ptr<StoreFixture>> fixtures;
  std::lock_guard<std::mutex> lock(mutex);
  auto& f = fixtures[n];
  if (!f) f = std::make_unique<StoreFixture>(n);
  return *f;
}

void BM_StoreThroughput(benchmark::State& state) {
  StoreFixture& f = SharedStore(static_cast<int>(state.range(0)));
  const std::string name = "robot-" + std::to_string(state.thread_index());
  size_t t = 0;
  for (auto _ : state) {
    f.store.Update("key", "map", name, 1, {}, SessionStore::Clock::now(), [&](SequenceState* st) {
      f.filter.Update(f.frames[t++ % f.frames.size()], st);
    });
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_StoreThroughput)->Arg(200)->Arg(10000)->Threads(1)->Threads(2)->UseRealTime();

}  // namespace
}  // namespace sceneloc

BENCHMARK_MAIN();
