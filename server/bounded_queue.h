// A fixed-capacity FIFO between one producer (the server's I/O thread) and its workers.
// Full means full: TryPush fails at once instead of waiting or growing, which is how the
// server turns overload into an immediate OVERLOADED reply.
//
// Thread-safe: every method may be called from any thread.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <optional>
#include <vector>

#include "common/util/mutex.h"
#include "common/util/thread_annotations.h"

namespace sceneloc {

template <typename T>
class BoundedQueue {
 public:
  // REQUIRES: capacity >= 1.
  explicit BoundedQueue(size_t capacity) : capacity_(capacity) {}

  // Appends `item` unless the queue is full or closed; on failure `item` is untouched.
  bool TryPush(T& item) EXCLUDES(mutex_) {
    {
      MutexLock lock(&mutex_);
      if (closed_ || items_.size() >= capacity_) return false;
      items_.push_back(std::move(item));
    }
    cv_.notify_one();
    return true;
  }

  // Waits for an item; nullopt once the queue is closed (items left in it at Close() are
  // returned by Close, not here).
  std::optional<T> Pop() EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    while (!closed_ && items_.empty()) lock.Wait(cv_);
    if (closed_) return std::nullopt;
    T item = std::move(items_.front());
    items_.pop_front();
    return item;
  }

  // Wakes every Pop() and refuses further pushes; returns the items nobody took.
  std::vector<T> Close() EXCLUDES(mutex_) {
    std::vector<T> left;
    {
      MutexLock lock(&mutex_);
      closed_ = true;
      for (T& item : items_) left.push_back(std::move(item));
      items_.clear();
    }
    cv_.notify_all();
    return left;
  }

  size_t size() const EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    return items_.size();
  }

 private:
  // Constant after construction.
  const size_t capacity_;

  mutable Mutex mutex_;
  std::condition_variable cv_;  // signalled when an item is pushed or the queue closes
  // Guarded by mutex_.
  std::deque<T> items_ GUARDED_BY(mutex_);
  bool closed_ GUARDED_BY(mutex_) = false;
};

}  // namespace sceneloc
