#include "common/util/mutex.h"

#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <thread>
#include <vector>

namespace sceneloc {
namespace {

using Clock = std::chrono::steady_clock;

// A counter guarded the way the server's classes guard their members.
class Counter {
 public:
  void Add() EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    ++count_;
  }
  int count() EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    return count_;
  }

 private:
  Mutex mutex_;
  int count_ GUARDED_BY(mutex_) = 0;
};

// MutexLock excludes other threads: no increment of many threads' is lost.
TEST(MutexTest, LockExcludesOtherThreads) {
  Counter counter;
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 10000; ++i) counter.Add();
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(counter.count(), 40000);
}

// Whether another thread can take `mutex` now (it releases it again at once).
bool FreeForOtherThreads(Mutex& mutex) {
  bool took = false;
  std::thread([&] {
    if (mutex.TryLock()) {
      took = true;
      mutex.Unlock();
    }
  }).join();
  return took;
}

// The lock is held for the MutexLock's scope, and released at its end or by Unlock().
TEST(MutexTest, HeldUntilScopeEndOrUnlock) {
  Mutex mutex;
  {
    MutexLock lock(&mutex);
    EXPECT_FALSE(FreeForOtherThreads(mutex));
  }
  EXPECT_TRUE(FreeForOtherThreads(mutex));

  MutexLock lock(&mutex);
  EXPECT_FALSE(FreeForOtherThreads(mutex));
  lock.Unlock();
  EXPECT_TRUE(FreeForOtherThreads(mutex));
}

// The std::lock_guard spelling works on Mutex too (lowercase lock/unlock).
TEST(MutexTest, WorksWithStdLockGuard) {
  Mutex mutex;
  {
    std::lock_guard<Mutex> guard(mutex);
    EXPECT_FALSE(FreeForOtherThreads(mutex));
  }
  EXPECT_TRUE(FreeForOtherThreads(mutex));
}

// Wait releases the mutex while waiting, so another thread can set the condition and
// notify; the waiter sees the condition with the mutex held again.
TEST(MutexTest, WaitSeesConditionSetByAnotherThread) {
  Mutex mutex;
  std::condition_variable cv;
  bool ready = false;
  int value = 0;
  std::thread setter([&] {
    MutexLock lock(&mutex);
    value = 42;
    ready = true;
    cv.notify_all();
  });
  {
    MutexLock lock(&mutex);
    while (!ready) lock.Wait(cv);
    EXPECT_EQ(value, 42);
  }
  setter.join();
}

// WaitUntil returns true when notified before the deadline.
TEST(MutexTest, WaitUntilReturnsTrueWhenNotified) {
  Mutex mutex;
  std::condition_variable cv;
  bool ready = false;
  std::thread setter([&] {
    MutexLock lock(&mutex);
    ready = true;
    cv.notify_all();
  });
  bool in_time = true;
  {
    // A deadline far away: only a notification ends the wait.
    const Clock::time_point deadline = Clock::now() + std::chrono::minutes(5);
    MutexLock lock(&mutex);
    while (!ready && in_time) in_time = lock.WaitUntil(cv, deadline);
    EXPECT_TRUE(ready);
  }
  setter.join();
  EXPECT_TRUE(in_time);
}

// Without a notification, WaitUntil and WaitFor return false at the timeout, not before,
// with the mutex held again.
TEST(MutexTest, WaitTimesOut) {
  Mutex mutex;
  std::condition_variable cv;
  MutexLock lock(&mutex);
  const Clock::time_point deadline = Clock::now() + std::chrono::milliseconds(50);
  bool in_time = true;
  while (in_time) in_time = lock.WaitUntil(cv, deadline);  // spurious wake-ups loop
  EXPECT_GE(Clock::now(), deadline);

  const Clock::time_point start = Clock::now();
  bool woken = true;
  while (woken) woken = lock.WaitFor(cv, std::chrono::milliseconds(20));
  EXPECT_GE(Clock::now() - start, std::chrono::milliseconds(20));

  EXPECT_FALSE(FreeForOtherThreads(mutex));  // held again after the timeouts
}

}  // namespace
}  // namespace sceneloc
