// A budget of bytes shared by concurrent work: here, the memory that JPEG decodes may hold
// at once across the workers (limits.max_decode_bytes). A decode reserves its estimated
// peak (EstimateDecodeBytes in jpeg_header.h) before it starts and returns it when the
// decoded image is gone; one that does not fit waits, up to its request's deadline.
//
// Thread-safe.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>

#include "common/util/mutex.h"
#include "common/util/thread_annotations.h"

namespace sceneloc {

class MemoryBudget {
 public:
  using Clock = std::chrono::steady_clock;

  explicit MemoryBudget(int64_t capacity) : capacity_(capacity) {}
  MemoryBudget(const MemoryBudget&) = delete;
  MemoryBudget& operator=(const MemoryBudget&) = delete;

  // Holds `bytes` of the budget until destroyed (or empty, when the reservation failed).
  class Lease {
   public:
    Lease() = default;
    Lease(Lease&& o) noexcept : budget_(o.budget_), bytes_(o.bytes_) { o.budget_ = nullptr; }
    Lease& operator=(Lease&&) = delete;
    Lease(const Lease&) = delete;
    ~Lease() {
      if (budget_ != nullptr) budget_->Release(bytes_);
    }
    bool held() const { return budget_ != nullptr; }

   private:
    friend class MemoryBudget;
    Lease(MemoryBudget* budget, int64_t bytes) : budget_(budget), bytes_(bytes) {}
    MemoryBudget* budget_ = nullptr;
    int64_t bytes_ = 0;
  };

  // Reserves `bytes`, waiting until they are free or `deadline` passes (then the lease is
  // not held). REQUIRES: 0 <= bytes <= capacity().
  Lease Acquire(int64_t bytes, Clock::time_point deadline) EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    while (in_use_ + bytes > capacity_) {
      if (!lock.WaitUntil(freed_, deadline) && in_use_ + bytes > capacity_) return Lease();
    }
    in_use_ += bytes;
    return Lease(this, bytes);
  }

  int64_t capacity() const { return capacity_; }
  int64_t in_use() const EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    return in_use_;
  }

 private:
  void Release(int64_t bytes) EXCLUDES(mutex_) {
    {
      MutexLock lock(&mutex_);
      in_use_ -= bytes;
    }
    freed_.notify_all();
  }

  // Constant after construction.
  const int64_t capacity_;

  mutable Mutex mutex_;
  std::condition_variable freed_;  // signalled when bytes are released
  // Guarded by mutex_.
  int64_t in_use_ GUARDED_BY(mutex_) = 0;
};

}  // namespace sceneloc
