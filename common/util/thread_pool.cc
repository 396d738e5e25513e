#include "common/util/thread_pool.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>

namespace sceneloc {
namespace {

// How long an idle thread polls for work before it sleeps on a condition variable. Waking
// a sleeping thread costs tens of microseconds (more on a VM), and one frame's extraction
// is some fifty parallel loops of 0.05-1 ms each, back to back: without the poll every loop
// waits for its helper to wake (on the 2-core VM of docs/results.md, a loop of 2 threads
// took 17 us more than its work; polling, 2 us). Idle, a thread polls this long, then sleeps.
constexpr auto kSpin = std::chrono::microseconds(50);

void CpuRelax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#else
  std::this_thread::yield();
#endif
}

// Polls `ready` until it returns true or kSpin has passed; returns its last answer.
template <typename Ready>
bool SpinUntil(const Ready& ready) {
  const auto deadline = std::chrono::steady_clock::now() + kSpin;
  for (int i = 0;; ++i) {
    if (ready()) return true;
    if ((i & 63) == 63 && std::chrono::steady_clock::now() > deadline) return false;
    CpuRelax();
  }
}

}  // namespace

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
    queued_.store(queue_.size(), std::memory_order_release);
  }
  cv_.notify_one();
}

void ThreadPool::WorkerLoop() {
  for (;;) {
    std::function<void()> task;
    SpinUntil([this] { return queued_.load(std::memory_order_acquire) != 0; });
    {
      MutexLock lock(&mutex_);
      while (!stopping_ && queue_.empty()) lock.Wait(cv_);
      if (queue_.empty()) return;  // stopping and drained
      task = std::move(queue_.front());
      queue_.pop_front();
      queued_.store(queue_.size(), std::memory_order_release);
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
  SpinUntil([&state, num_chunks] { return state->done.load() == num_chunks; });
  MutexLock lock(&state->mutex);
  while (state->done.load() != num_chunks) lock.Wait(state->cv);
  if (state->error) std::rethrow_exception(state->error);
}

}  // namespace sceneloc
