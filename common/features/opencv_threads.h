// OpenCV's own parallel loops on sceneloc's thread pool.
//
// SIFT runs parts of itself as OpenCV parallel loops (the difference-of-Gaussians layers,
// the extremum search per layer, the descriptors per keypoint). Left to OpenCV's backend
// (TBB on Debian) they would start threads of their own beside the server's workers and
// oversubscribe the cores under load; pinned to one thread (what the server did before)
// a lone request uses one core of two. Routed to the server's engine pool instead, they
// follow the pool's rule: the calling thread works on its own loop and idle pool threads
// join it, so an idle server spreads one frame's extraction over every core and a busy
// one runs each frame on its own worker (ThreadPool::ParallelFor).
#pragma once

#include <atomic>

#include "common/util/thread_pool.h"

namespace sceneloc {

// While alive, OpenCV's parallel loops run on `pool` (which must outlive this object).
// Process-wide: create at most one, from main, before the threads that use OpenCV start
// (OpenCV's backend switch is not thread-safe). On destruction OpenCV goes back to
// running every loop on its caller.
class OpenCvOnThreadPool {
 public:
  explicit OpenCvOnThreadPool(ThreadPool* pool);
  ~OpenCvOnThreadPool();
  OpenCvOnThreadPool(const OpenCvOnThreadPool&) = delete;
  OpenCvOnThreadPool& operator=(const OpenCvOnThreadPool&) = delete;
};

// Runs OpenCV's parallel loops on their caller only (what `cv::setNumThreads(1)` does).
void OpenCvSerial();

}  // namespace sceneloc
