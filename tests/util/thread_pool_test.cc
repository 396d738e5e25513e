#include "common/util/thread_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <new>
#include <stdexcept>
#include <thread>
#include <vector>

namespace sceneloc {
namespace {

// Every index in [0, n) is visited exactly once, for several pool and problem sizes.
TEST(ThreadPoolTest, ParallelForVisitsEveryIndexOnce) {
  for (int threads : {1, 2, 4}) {
    ThreadPool pool(threads);
    for (size_t n : {0u, 1u, 7u, 1000u}) {
      std::vector<std::atomic<int>> hits(n);
      pool.ParallelFor(n, 1, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) hits[i]++;
      });
      for (size_t i = 0; i < n; ++i) EXPECT_EQ(hits[i].load(), 1) << threads << " " << n;
    }
  }
}

// Concurrent ParallelFor calls from several threads, nested ones included, all complete.
TEST(ThreadPoolTest, ConcurrentAndNestedCallsComplete) {
  ThreadPool pool(2);
  std::atomic<long> total{0};
  std::vector<std::thread> callers;
  for (int c = 0; c < 4; ++c) {
    callers.emplace_back([&] {
      pool.ParallelFor(50, 1, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
          pool.ParallelFor(10, 1, [&](size_t b2, size_t e2) { total += long(e2 - b2); });
        }
      });
    });
  }
  for (auto& t : callers) t.join();
  EXPECT_EQ(total.load(), 4 * 50 * 10);
}

// With more than one thread, work really runs on more than one thread.
TEST(ThreadPoolTest, UsesWorkerThreads) {
  ThreadPool pool(2);
  std::atomic<int> inside{0};
  std::atomic<int> peak{0};
  pool.ParallelFor(8, 1, [&](size_t, size_t) {
    const int now = ++inside;
    int expected = peak.load();
    while (now > expected && !peak.compare_exchange_weak(expected, now)) {
    }
    // Hold the chunk until a second thread has entered (or a generous deadline passes).
    for (int spin = 0; spin < 2000000 && peak.load() < 2; ++spin) std::this_thread::yield();
    --inside;
  });
  EXPECT_EQ(peak.load(), 2);
}

// Idle workers first poll for work, then sleep (thread_pool.cc, kSpin): a task scheduled
// at any moment of that, just after the last, while they poll or long after they sleep,
// runs on a worker; and a pool destroyed while its workers poll joins them.
TEST(ThreadPoolTest, TasksReachWorkersWhetherTheyPollOrSleep) {
  ThreadPool pool(2);
  const std::thread::id caller = std::this_thread::get_id();
  for (const int gap_us : {0, 5, 20, 45, 60, 200, 3000}) {
    for (int round = 0; round < 5; ++round) {
      std::this_thread::sleep_for(std::chrono::microseconds(gap_us));
      std::atomic<bool> ran{false};
      std::atomic<bool> on_worker{false};
      pool.Schedule([&] {
        on_worker = std::this_thread::get_id() != caller;
        ran = true;
      });
      while (!ran.load()) std::this_thread::yield();
      EXPECT_TRUE(on_worker.load()) << gap_us;
    }
  }
  for (int i = 0; i < 20; ++i) {
    ThreadPool short_lived(3);
    std::atomic<int> sum{0};
    short_lived.ParallelFor(6, 1, [&](size_t b, size_t e) { sum += static_cast<int>(e - b); });
    EXPECT_EQ(sum.load(), 6);
  }
}

}  // namespace
}  // namespace sceneloc

namespace sceneloc {
namespace {

// An exception in any chunk (on a worker or the caller) reaches the caller once the loop
// has settled, the process lives, and the pool keeps working; a scheduled task that throws
// is dropped without taking the worker down.
TEST(ThreadPoolTest, ExceptionsReachTheCallerAndThePoolSurvives) {
  ThreadPool pool(3);
  for (int round = 0; round < 20; ++round) {
    EXPECT_THROW(pool.ParallelFor(1000, 1,
                                  [&](size_t begin, size_t end) {
                                    for (size_t i = begin; i < end; ++i) {
                                      if (i == 777) throw std::bad_alloc();
                                    }
                                  }),
                 std::bad_alloc);
  }
  pool.Schedule([] { throw std::runtime_error("dropped"); });
  std::atomic<size_t> sum{0};
  pool.ParallelFor(1000, 1, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) sum += i;
  });
  EXPECT_EQ(sum.load(), 999u * 1000u / 2u);
}

}  // namespace
}  // namespace sceneloc
