// A fixed pool of worker threads and a ParallelFor on top of it.
//
// Thread-safe: Schedule() and ParallelFor() may be called from any number of threads at
// once, including from inside a task. ParallelFor's caller works on its own loop too, so a
// ParallelFor never waits on a pool that is busy with other callers' work: it degrades
// to running inline, which is what the server wants under load (no request waits for
// another request's scoring to finish before its own can start).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <memory>
#include <thread>
#include <vector>

#include "common/util/mutex.h"
#include "common/util/thread_annotations.h"

namespace sceneloc {

class ThreadPool {
 public:
  // num_threads <= 1 creates no worker: every ParallelFor runs inline on the caller.
  explicit ThreadPool(int num_threads);
  ~ThreadPool();  // finishes queued tasks, then joins the workers
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  // Number of threads that run a ParallelFor: the workers plus the caller, at least 1.
  int num_threads() const { return num_threads_; }

  // Runs `task` on a worker (inline without workers). An exception it throws on a worker
  // is dropped: tasks report their own errors.
  void Schedule(std::function<void()> task) EXCLUDES(mutex_);

  // Calls fn(begin, end) over [0, n) split into contiguous chunks of at least min_chunk
  // items; returns when every chunk is done. Runs inline when there is one thread or
  // one chunk. If fn throws (std::bad_alloc, say), the remaining chunks are skipped and
  // the first exception is rethrown on the caller once every started chunk has finished;
  // no pool thread ever ends the process.
  void ParallelFor(size_t n, size_t min_chunk,
                   const std::function<void(size_t begin, size_t end)>& fn) EXCLUDES(mutex_);

 private:
  void WorkerLoop() EXCLUDES(mutex_);

  // Constant after construction.
  const int num_threads_;
  std::vector<std::thread> workers_;  // joined by the destructor

  Mutex mutex_;
  std::condition_variable cv_;  // signalled when a task is queued or stopping_ is set
  // Guarded by mutex_.
  std::deque<std::function<void()>> queue_ GUARDED_BY(mutex_);
  bool stopping_ GUARDED_BY(mutex_) = false;
  // queue_.size(), readable without the lock: what an idle worker spins on (WorkerLoop).
  std::atomic<size_t> queued_{0};
};

}  // namespace sceneloc
