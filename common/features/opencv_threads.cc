#include "common/features/opencv_threads.h"

#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/core/parallel/parallel_backend.hpp>

namespace sceneloc {
namespace {

// The backend OpenCV calls for every parallel loop once installed. OpenCV keeps it for
// the life of the process, so it outlives the pool: the pool pointer is cleared (and
// OpenCV set to one thread, so it stops calling) before the pool goes.
class PoolBackend final : public cv::parallel::ParallelForAPI {
 public:
  void parallel_for(int tasks, FN_parallel_for_body_cb_t body, void* data) override {
    ThreadPool* pool = pool_.load();
    if (pool == nullptr || tasks <= 1) {
      if (tasks > 0) body(0, tasks, data);
      return;
    }
    pool->ParallelFor(static_cast<size_t>(tasks), 1, [body, data](size_t begin, size_t end) {
      body(static_cast<int>(begin), static_cast<int>(end), data);
    });
  }
  // Deprecated in OpenCV 4 and read by none of the functions sceneloc calls.
  int getThreadNum() const override { return 0; }
  int getNumThreads() const override {
    ThreadPool* pool = pool_.load();
    return pool == nullptr ? 1 : pool->num_threads();
  }
  // The pool's size is fixed; cv::setNumThreads only switches loops on (> 1) or off.
  int setNumThreads(int) override { return getNumThreads(); }
  const char* getName() const override { return "sceneloc-thread-pool"; }

  void set_pool(ThreadPool* pool) { pool_.store(pool); }

 private:
  std::atomic<ThreadPool*> pool_{nullptr};
};

std::shared_ptr<PoolBackend>& Backend() {
  static auto* backend = new std::shared_ptr<PoolBackend>(std::make_shared<PoolBackend>());
  return *backend;
}

}  // namespace

OpenCvOnThreadPool::OpenCvOnThreadPool(ThreadPool* pool) {
  Backend()->set_pool(pool);
  cv::parallel::setParallelForBackend(Backend(), /*propagateNumThreads=*/false);
  // OpenCV calls the backend only while its thread count is above one.
  cv::setNumThreads(pool->num_threads());
}

OpenCvOnThreadPool::~OpenCvOnThreadPool() {
  OpenCvSerial();
  Backend()->set_pool(nullptr);
}

void OpenCvSerial() { cv::setNumThreads(1); }

}  // namespace sceneloc
