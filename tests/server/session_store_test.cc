#include "server/session_store.h"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <vector>

namespace sceneloc {
namespace {

using Clock = SessionStore::Clock;
using std::chrono::seconds;

// A step that counts frames in the state as the filter does (one float per frame).
void Step(SequenceState* state) {
  state->location.push_back(1.0f);
  ++state->frames;
}

SessionOptions Options(int64_t max_sessions, double idle_timeout_s = 600) {
  SessionOptions o;
  o.max_sessions = max_sessions;
  o.idle_timeout_s = idle_timeout_s;
  return o;
}

// Frames of one session go to one state; the first is NEW, the rest CONTINUED.
TEST(SessionStoreTest, FramesOfOneSessionShareTheirState) {
  SessionStore store(Options(10));
  const Clock::time_point t0 = Clock::now();
  uint32_t frames = 0;
  const auto count = [&](SequenceState* s) {
    Step(s);
    frames = s->frames;
  };
  EXPECT_EQ(store.Update("", "map", "robot", 1, {}, t0, count), SessionStart::kNew);
  EXPECT_EQ(store.Update("", "map", "robot", 1, {}, t0, count), SessionStart::kContinued);
  EXPECT_EQ(store.Update("", "map", "robot", 1, {}, t0, count), SessionStart::kContinued);
  EXPECT_EQ(frames, 3u);
  EXPECT_EQ(store.Counts().live, 1u);
}

// Client key, map and name each make a different session.
TEST(SessionStoreTest, KeyedByClientMapAndName) {
  SessionStore store(Options(10));
  const Clock::time_point t0 = Clock::now();
  EXPECT_EQ(store.Update("alice", "map", "r", 1, {}, t0, Step), SessionStart::kNew);
  EXPECT_EQ(store.Update("bob", "map", "r", 1, {}, t0, Step), SessionStart::kNew);
  EXPECT_EQ(store.Update("alice", "other", "r", 1, {}, t0, Step), SessionStart::kNew);
  EXPECT_EQ(store.Update("alice", "map", "r2", 1, {}, t0, Step), SessionStart::kNew);
  // No ambiguity from joining: ("a", "b\0c") style collisions cannot be built from
  // printable names, but ("ab", "c") vs ("a", "bc") can.
  EXPECT_EQ(store.Update("ab", "c", "r", 1, {}, t0, Step), SessionStart::kNew);
  EXPECT_EQ(store.Update("a", "bc", "r", 1, {}, t0, Step), SessionStart::kNew);
  EXPECT_EQ(store.Counts().live, 6u);
}

// reset starts the session again; a new generation of its map does too.
TEST(SessionStoreTest, ResetAndMapReloadStartAgain) {
  SessionStore store(Options(10));
  const Clock::time_point t0 = Clock::now();
  uint32_t frames = 0;
  const auto count = [&](SequenceState* s) {
    Step(s);
    frames = s->frames;
  };
  store.Update("", "map", "r", 1, {}, t0, count);
  store.Update("", "map", "r", 1, {}, t0, count);
  EXPECT_EQ(store.Update("", "map", "r", 1, SessionSeed{true}, t0, count), SessionStart::kReset);
  EXPECT_EQ(frames, 1u);
  store.Update("", "map", "r", 1, {}, t0, count);
  EXPECT_EQ(store.Update("", "map", "r", 2, {}, t0, count), SessionStart::kMapReloaded);
  EXPECT_EQ(frames, 1u);
  EXPECT_EQ(store.Update("", "map", "r", 2, {}, t0, count), SessionStart::kContinued);
  EXPECT_EQ(frames, 2u);
}

// Beyond max_sessions the least recently used session is dropped: a session used since is
// kept.
TEST(SessionStoreTest, LeastRecentlyUsedIsEvicted) {
  SessionStore store(Options(2));
  const Clock::time_point t0 = Clock::now();
  store.Update("", "m", "a", 1, {}, t0, Step);
  store.Update("", "m", "b", 1, {}, t0, Step);
  store.Update("", "m", "a", 1, {}, t0, Step);  // a is now the most recent
  store.Update("", "m", "c", 1, {}, t0, Step);  // drops b
  EXPECT_EQ(store.Counts().live, 2u);
  EXPECT_EQ(store.Counts().evicted, 1u);
  EXPECT_EQ(store.Update("", "m", "a", 1, {}, t0, Step), SessionStart::kContinued);
  EXPECT_EQ(store.Update("", "m", "b", 1, {}, t0, Step), SessionStart::kNew);
}

// A session idle past the timeout is dropped; one used within it is kept.
TEST(SessionStoreTest, IdleSessionsExpire) {
  SessionStore store(Options(10, 60));
  const Clock::time_point t0 = Clock::now();
  store.Update("", "m", "old", 1, {}, t0, Step);
  store.Update("", "m", "busy", 1, {}, t0 + seconds(50), Step);
  EXPECT_EQ(store.Update("", "m", "busy", 1, {}, t0 + seconds(100), Step),
            SessionStart::kContinued);
  EXPECT_EQ(store.Counts().expired, 1u);  // "old", idle 100 s
  EXPECT_EQ(store.Update("", "m", "old", 1, {}, t0 + seconds(100), Step), SessionStart::kNew);
}

// The memory reported grows with the sessions and their states and falls when they go.
TEST(SessionStoreTest, MemoryIsCounted) {
  SessionStore store(Options(1000, 60));
  const Clock::time_point t0 = Clock::now();
  EXPECT_EQ(store.Counts().memory_bytes, 0u);
  const auto big = [](SequenceState* s) { s->location.assign(1001, 0.001f); };
  for (int i = 0; i < 100; ++i) store.Update("", "m", std::to_string(i), 1, {}, t0, big);
  const SessionCounts c = store.Counts();
  EXPECT_EQ(c.live, 100u);
  EXPECT_GE(c.memory_bytes, 100u * 1001 * sizeof(float));
  EXPECT_LT(c.memory_bytes, 100u * (1001 * sizeof(float) + 1024));
  store.Update("", "m", "last", 1, {}, t0 + seconds(61), Step);  // the 100 expire
  EXPECT_EQ(store.Counts().live, 1u);
  EXPECT_LT(store.Counts().memory_bytes, 1024u);
}

// A state's memory counts its three parts: the locations, the tracked ones and their speeds.
TEST(SessionStoreTest, EveryPartOfAStateIsCounted) {
  SessionStore store(Options(10));
  const auto state = [](SequenceState* s) {
    s->location.assign(1000, 0.001f);
    s->tracked.assign(100, 0);
    s->speeds.assign(2000, 0.5f);
  };
  store.Update("", "m", "one", 1, {}, Clock::now(), state);
  EXPECT_GE(store.Counts().memory_bytes, (1000 + 100 + 2000) * sizeof(float));
}

// The states together stay within max_state_bytes: the least recently used go first, the
// session just updated never, even when it alone passes the limit.
TEST(SessionStoreTest, StateBytesAreBounded) {
  SessionOptions options = Options(1000);
  options.max_state_bytes = 10 * 1000 * sizeof(float);  // ten states of 1000 locations
  SessionStore store(options);
  const Clock::time_point t0 = Clock::now();
  const auto state = [](SequenceState* s) { s->location.assign(1000, 0.001f); };
  for (int i = 0; i < 25; ++i) store.Update("", "m", std::to_string(i), 1, {}, t0, state);
  EXPECT_EQ(store.Counts().live, 10u);
  EXPECT_EQ(store.Counts().evicted, 15u);
  EXPECT_EQ(store.Update("", "m", "24", 1, {}, t0, state), SessionStart::kContinued);
  EXPECT_EQ(store.Update("", "m", "0", 1, {}, t0, state), SessionStart::kNew);
  const auto huge = [](SequenceState* s) { s->location.assign(20000, 0.001f); };
  store.Update("", "m", "huge", 1, {}, t0, huge);
  EXPECT_EQ(store.Counts().live, 1u);
  EXPECT_EQ(store.Update("", "m", "huge", 1, {}, t0, huge), SessionStart::kContinued);
}

// Many threads on many sessions at once: every frame lands in its own session.
TEST(SessionStoreTest, ConcurrentUpdates) {
  SessionStore store(Options(1000));
  constexpr int kThreads = 4, kSessions = 8, kFrames = 200;
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&store, t] {
      for (int f = 0; f < kFrames; ++f) {
        store.Update("", "m", std::to_string((t + f) % kSessions), 1, {}, Clock::now(),
                     [](SequenceState* s) { ++s->frames; });
      }
    });
  }
  for (auto& th : threads) th.join();
  uint32_t total = 0;
  for (int s = 0; s < kSessions; ++s) {
    store.Update("", "m", std::to_string(s), 1, {}, Clock::now(),
                 [&](SequenceState* state) { total += state->frames; });
  }
  EXPECT_EQ(total, static_cast<uint32_t>(kThreads * kFrames));
}

// Frames of different sessions are filtered at the same time (the store's lock is not held
// for a filter update): each step waits for the other session's step to begin, which under
// one lock would never happen. Frames of one session never overlap.
TEST(SessionStoreTest, DifferentSessionsUpdateInParallel) {
  SessionStore store(Options(10));
  std::atomic<int> inside{0};
  std::atomic<bool> overlapped[2] = {false, false};
  std::vector<std::thread> threads;
  for (int t = 0; t < 2; ++t) {
    threads.emplace_back([&, t] {
      store.Update("", "m", t == 0 ? "a" : "b", 1, {}, Clock::now(), [&](SequenceState* s) {
        ++inside;
        const auto deadline = Clock::now() + seconds(10);
        while (inside.load() < 2 && Clock::now() < deadline) std::this_thread::yield();
        overlapped[t] = inside.load() == 2;
        ++s->frames;
      });
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_TRUE(overlapped[0]);
  EXPECT_TRUE(overlapped[1]);

  std::atomic<int> in_one{0};
  std::atomic<int> most{0};
  threads.clear();
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int f = 0; f < 50; ++f) {
        store.Update("", "m", "one", 1, {}, Clock::now(), [&](SequenceState* s) {
          const int now_inside = ++in_one;
          int seen = most.load();
          while (now_inside > seen && !most.compare_exchange_weak(seen, now_inside)) {
          }
          std::this_thread::yield();
          ++s->frames;
          --in_one;
        });
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(most.load(), 1);
  uint32_t frames = 0;
  store.Update("", "m", "one", 1, {}, Clock::now(), [&](SequenceState* s) { frames = s->frames; });
  EXPECT_EQ(frames, 200u);
}

// A session dropped while its frame is being filtered: the update finishes on the state it
// holds, the store's count of state bytes stays exact, and the name starts again next time.
TEST(SessionStoreTest, DroppedWhileUpdating) {
  SessionOptions o = Options(1);
  SessionStore store(o);
  std::atomic<bool> in_step{false}, dropped{false};
  std::thread slow([&] {
    store.Update("", "m", "slow", 1, {}, Clock::now(), [&](SequenceState* s) {
      in_step = true;
      while (!dropped) std::this_thread::yield();
      s->location.assign(1000, 1.0f);
    });
  });
  while (!in_step) std::this_thread::yield();
  // max_sessions 1: a new session drops "slow" while its step runs.
  EXPECT_EQ(store.Update("", "m", "other", 1, {}, Clock::now(), Step), SessionStart::kNew);
  dropped = true;
  slow.join();
  const SessionCounts counts = store.Counts();
  EXPECT_EQ(counts.live, 1u);
  EXPECT_EQ(counts.evicted, 1u);
  EXPECT_LT(counts.memory_bytes, 1000 * sizeof(float));  // "slow"'s state is not counted
  EXPECT_EQ(store.Update("", "m", "slow", 1, {}, Clock::now(), Step), SessionStart::kNew);
}

// Settings out of range are refused.
TEST(SessionStoreTest, OptionsValidate) {
  EXPECT_TRUE(SessionOptions{}.Validate().ok());
  EXPECT_FALSE(Options(0).Validate().ok());
  EXPECT_FALSE(Options(10, 0).Validate().ok());
  EXPECT_FALSE(Options(10, -1).Validate().ok());
  SessionOptions no_bytes;
  no_bytes.max_state_bytes = 0;
  EXPECT_FALSE(no_bytes.Validate().ok());
}

}  // namespace
}  // namespace sceneloc
