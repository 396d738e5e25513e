// A fixed-capacity FIFO between one producer (the server's I/O thread) and its workers.
// Full means full: TryPush fails at once instead of waiting or growing, which is how the
// server turns overload into an immediate OVERLOADED reply.
//
// Items are small or large. At most `large_holders` consumers hold a large item at once
// (from Pop until its Done), so with more consumers than that some are always free for
// small items: a flood of large requests cannot take every worker from the small ones. A
// consumer takes the oldest item it may: the oldest of all, unless that is large and the
// large holders are all busy, when it takes the oldest small item.
//
// Thread-safe: every method may be called from any thread.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "common/util/check.h"
#include "common/util/mutex.h"
#include "common/util/thread_annotations.h"

namespace sceneloc {

template <typename T>
class BoundedQueue {
 public:
  // REQUIRES: capacity >= 1, large_holders >= 1.
  explicit BoundedQueue(size_t capacity, int large_holders = std::numeric_limits<int>::max())
      : capacity_(capacity), large_holders_(large_holders) {}

  // Appends `item` unless the queue is full or closed; on failure `item` is untouched.
  bool TryPush(T& item, bool large = false) EXCLUDES(mutex_) {
    {
      MutexLock lock(&mutex_);
      if (closed_ || small_.size() + large_.size() >= capacity_) return false;
      (large ? large_ : small_).push_back({next_++, std::move(item)});
    }
    cv_.notify_one();
    return true;
  }

  // Waits for an item this consumer may take; nullopt once the queue is closed (items left
  // in it at Close() are returned by Close, not here). *large says whether it is large: a
  // large item counts against large_holders until Done(true).
  std::optional<T> Pop(bool* large = nullptr) EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    while (!closed_ && Next() == nullptr) lock.Wait(cv_);
    if (closed_) return std::nullopt;
    return Take(large);
  }

  // Pop without waiting: nullopt when no item may be taken now (or the queue is closed).
  std::optional<T> TryPop(bool* large = nullptr) EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    if (closed_ || Next() == nullptr) return std::nullopt;
    return Take(large);
  }

  // A consumer has finished with an item it popped; `large` as Pop said.
  void Done(bool large) EXCLUDES(mutex_) {
    if (!large) return;
    {
      MutexLock lock(&mutex_);
      SCENELOC_CHECK(large_held_ > 0) << "Done(true) without a large item held";
      --large_held_;
    }
    cv_.notify_all();  // a waiting consumer may take a large item now
  }

  // Wakes every Pop() and refuses further pushes; returns the items nobody took, oldest
  // first.
  std::vector<T> Close() EXCLUDES(mutex_) {
    std::vector<T> left;
    {
      MutexLock lock(&mutex_);
      closed_ = true;
      while (!small_.empty() || !large_.empty()) {
        const bool small_first =
            large_.empty() || (!small_.empty() && small_.front().first < large_.front().first);
        std::deque<Entry>& lane = small_first ? small_ : large_;
        left.push_back(std::move(lane.front().second));
        lane.pop_front();
      }
    }
    cv_.notify_all();
    return left;
  }

  size_t size() const EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    return small_.size() + large_.size();
  }

  // The items waiting in one lane.
  size_t size_of(bool large) const EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    return large ? large_.size() : small_.size();
  }

  // Large items popped and not yet Done.
  int large_held() const EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    return large_held_;
  }

 private:
  using Entry = std::pair<uint64_t, T>;  // (arrival order, item)

  // The lane of the item a consumer would take now, null for none.
  std::deque<Entry>* Next() REQUIRES(mutex_) {
    const bool may_take_large = !large_.empty() && large_held_ < large_holders_;
    if (may_take_large && (small_.empty() || large_.front().first < small_.front().first)) {
      return &large_;
    }
    return small_.empty() ? nullptr : &small_;
  }

  T Take(bool* large) REQUIRES(mutex_) {
    std::deque<Entry>* lane = Next();
    const bool is_large = lane == &large_;
    large_held_ += is_large;
    if (large != nullptr) *large = is_large;
    T item = std::move(lane->front().second);
    lane->pop_front();
    return item;
  }

  // Constant after construction.
  const size_t capacity_;
  const int large_holders_;

  mutable Mutex mutex_;
  std::condition_variable cv_;  // signalled on a push, a large item's Done and on Close
  // Guarded by mutex_.
  std::deque<Entry> small_ GUARDED_BY(mutex_);
  std::deque<Entry> large_ GUARDED_BY(mutex_);
  uint64_t next_ GUARDED_BY(mutex_) = 0;
  int large_held_ GUARDED_BY(mutex_) = 0;
  bool closed_ GUARDED_BY(mutex_) = false;
};

}  // namespace sceneloc
