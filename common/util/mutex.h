// A mutex and its scoped lock, annotated for clang's thread-safety analysis
// (common/util/thread_annotations.h): libstdc++'s std::mutex and std::lock_guard carry no
// annotations, so members guarded by a std::mutex cannot be checked.
//
//   Mutex mutex_;
//   std::condition_variable cv_;
//   bool ready_ GUARDED_BY(mutex_) = false;
//
//   void WaitReady() EXCLUDES(mutex_) {
//     MutexLock lock(&mutex_);
//     while (!ready_) lock.Wait(cv_);  // ready_ is read with mutex_ held: checked
//   }
//
// Wait loops are written out as above rather than with a predicate lambda: a lambda is a
// function of its own to the analysis, which does not know that it runs under the lock.
//
// Thread-safe, as std::mutex.
#pragma once

#include <chrono>
#include <condition_variable>
#include <mutex>

#include "common/util/thread_annotations.h"

namespace sceneloc {

// A std::mutex the analysis knows. Not recursive.
class CAPABILITY("mutex") Mutex {
 public:
  Mutex() = default;
  Mutex(const Mutex&) = delete;
  Mutex& operator=(const Mutex&) = delete;

  void Lock() ACQUIRE() { mutex_.lock(); }
  void Unlock() RELEASE() { mutex_.unlock(); }
  // True when it took the lock; never waits.
  bool TryLock() TRY_ACQUIRE(true) { return mutex_.try_lock(); }

  // The standard's Lockable names, so std::lock_guard<Mutex> and the like work too.
  void lock() ACQUIRE() { Lock(); }
  void unlock() RELEASE() { Unlock(); }
  bool try_lock() TRY_ACQUIRE(true) { return TryLock(); }

 private:
  friend class MutexLock;
  std::mutex mutex_;
};

// Holds a Mutex from construction until destruction or Unlock(), whichever is first. While
// held it can wait on a std::condition_variable (which releases the mutex during the wait
// and holds it again on return, as std::condition_variable::wait does).
class SCOPED_CAPABILITY MutexLock {
 public:
  explicit MutexLock(Mutex* mutex) ACQUIRE(mutex) : lock_(mutex->mutex_) {}
  ~MutexLock() RELEASE() {}  // unlocks unless Unlock() already has
  MutexLock(const MutexLock&) = delete;
  MutexLock& operator=(const MutexLock&) = delete;

  // Releases the mutex before the end of the scope. REQUIRES: still held.
  void Unlock() RELEASE() { lock_.unlock(); }

  // Waits until `cv` is notified (or wakes spuriously): callers loop on their condition.
  // REQUIRES: held.
  void Wait(std::condition_variable& cv) { cv.wait(lock_); }

  // As Wait, but gives up at `deadline`: false when it timed out, true when woken before
  // (notified or spuriously). Either way the mutex is held again on return.
  template <typename Clock, typename Duration>
  bool WaitUntil(std::condition_variable& cv,
                 const std::chrono::time_point<Clock, Duration>& deadline) {
    return cv.wait_until(lock_, deadline) == std::cv_status::no_timeout;
  }

  // As WaitUntil, `timeout` from now. A loop should wait until a deadline instead, or each
  // spurious wake-up starts the timeout again.
  template <typename Rep, typename Period>
  bool WaitFor(std::condition_variable& cv, const std::chrono::duration<Rep, Period>& timeout) {
    return cv.wait_for(lock_, timeout) == std::cv_status::no_timeout;
  }

 private:
  std::unique_lock<std::mutex> lock_;
};

}  // namespace sceneloc
