#include "common/util/thread_pool.h"

#include <algorithm>
#include <atomic>
#include <exception>

namespace sceneloc {

ThreadPool::ThreadPool(int num_threads) : num_threads_(std::max(1, num_threads)) {
  for (int i = 1; i < num_threads_; ++i) workers_.emplace_back([this] { WorkerLoop(); });
}

ThreadPool::~ThreadPool() {
  {
    MutexLock lock(&mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  for (auto& worker : workers_) worker.join();
}

void ThreadPool::Schedule(std::function<void()> task) {
  if (workers_.empty()) {
    task();
    return;
  }
  {
    MutexLock lock(&mutex_);
    queue_.push_back(std::move(task));
  }
  cv_.notify_one();
}

void ThreadPool::WorkerLoop() {
  for (;;) {
    std::function<void()> task;
    {
      MutexLock lock(&mutex_);
      while (!stopping_ && queue_.empty()) lock.Wait(cv_);
      if (queue_.empty()) return;  // stopping and drained
      task = std::move(queue_.front());
      queue_.pop_front();
    }
    // A pool thread must never end the process: ParallelFor's tasks hand their exception
    // to the caller; anything else a task throws is dropped here.
    try {
      task();
    } catch (...) {
    }
  }
}

namespace {

// Shared between the caller and the helpers of one ParallelFor. Helpers may start after
// the caller has already returned (they find no chunk left), hence the shared_ptr.
struct LoopState {
  size_t n = 0;
  size_t chunk = 0;
  size_t num_chunks = 0;
  std::function<void(size_t, size_t)> fn;
  std::atomic<size_t> next{0};
  std::atomic<size_t> done{0};
  std::atomic<bool> failed{false};
  Mutex mutex;
  std::condition_variable cv;                  // signalled when the last chunk is done
  std::exception_ptr error GUARDED_BY(mutex);  // the first exception a chunk threw

  // Runs chunks until none is left. After a chunk has thrown, the rest are skipped (but
  // still counted, so the caller's wait ends) and the caller rethrows the first exception.
  void Drain() {
    for (;;) {
      const size_t c = next.fetch_add(1);
      if (c >= num_chunks) return;
      const size_t begin = c * chunk;
      if (!failed.load()) {
        try {
          fn(begin, std::min(n, begin + chunk));
        } catch (...) {
          MutexLock lock(&mutex);
          if (!error) error = std::current_exception();
          failed = true;
        }
      }
      if (done.fetch_add(1) + 1 == num_chunks) {
        // Under the lock, so the notification cannot fall between the caller's check of
        // `done` and its wait.
        MutexLock lock(&mutex);
        cv.notify_all();
      }
    }
  }
};

}  // namespace

void ThreadPool::ParallelFor(size_t n, size_t min_chunk,
                             const std::function<void(size_t, size_t)>& fn) {
  if (n == 0) return;
  min_chunk = std::max<size_t>(1, min_chunk);
  // Several chunks per thread balance uneven work (e.g. RANSAC runs of different lengths)
  // without much scheduling overhead; a short loop gets one item per chunk.
  const size_t target_chunks = static_cast<size_t>(num_threads_) * 8;
  const size_t chunk = std::max(min_chunk, n / target_chunks);
  const size_t num_chunks = (n + chunk - 1) / chunk;
  if (num_threads_ == 1 || num_chunks == 1) {
    fn(0, n);
    return;
  }
  auto state = std::make_shared<LoopState>();
  state->n = n;
  state->chunk = chunk;
  state->num_chunks = num_chunks;
  state->fn = fn;
  const size_t helpers = std::min(num_chunks - 1, workers_.size());
  for (size_t i = 0; i < helpers; ++i) Schedule([state] { state->Drain(); });
  state->Drain();
  MutexLock lock(&state->mutex);
  while (state->done.load() != num_chunks) lock.Wait(state->cv);
  if (state->error) std::rethrow_exception(state->error);
}

}  // namespace sceneloc
