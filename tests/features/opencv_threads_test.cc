#include "common/features/opencv_threads.h"

#include <gtest/gtest.h>

#include <chrono>
#include <mutex>
#include <opencv2/core.hpp>
#include <set>
#include <thread>
#include <vector>

namespace sceneloc {
namespace {

// Runs an OpenCV parallel loop of `n` slow items; returns the threads that ran it, and
// checks that every item ran exactly once.
std::set<std::thread::id> LoopThreads(int n) {
  std::mutex mutex;
  std::set<std::thread::id> threads;
  std::vector<int> runs(static_cast<size_t>(n), 0);
  cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      std::lock_guard<std::mutex> lock(mutex);
      ++runs[static_cast<size_t>(i)];
      threads.insert(std::this_thread::get_id());
    }
  });
  for (int i = 0; i < n; ++i) EXPECT_EQ(runs[static_cast<size_t>(i)], 1) << i;
  return threads;
}

// On an idle pool an OpenCV loop spreads over the pool's threads; the caller works too;
// once the routing ends, loops run on their caller alone.
TEST(OpenCvThreadsTest, LoopsRunOnThePoolWhileRouted) {
  ThreadPool pool(2);
  {
    OpenCvOnThreadPool routed(&pool);
    EXPECT_EQ(cv::getNumThreads(), 2);
    const std::set<std::thread::id> threads = LoopThreads(64);
    EXPECT_EQ(threads.size(), 2u);
    EXPECT_EQ(threads.count(std::this_thread::get_id()), 1u);
  }
  const std::set<std::thread::id> alone = LoopThreads(16);
  ASSERT_EQ(alone.size(), 1u);
  EXPECT_EQ(*alone.begin(), std::this_thread::get_id());
}

// A pool of one thread is no pool: loops stay on the caller.
TEST(OpenCvThreadsTest, OneThreadMeansSerial) {
  ThreadPool pool(1);
  OpenCvOnThreadPool routed(&pool);
  const std::set<std::thread::id> threads = LoopThreads(16);
  ASSERT_EQ(threads.size(), 1u);
  EXPECT_EQ(*threads.begin(), std::this_thread::get_id());
}

// Busy pool threads are not waited for: a loop started while the pool's only other thread
// is held by another task completes on its caller.
TEST(OpenCvThreadsTest, BusyPoolDegradesToTheCaller) {
  ThreadPool pool(2);
  OpenCvOnThreadPool routed(&pool);
  std::mutex hold;
  std::unique_lock<std::mutex> held(hold);
  pool.Schedule([&hold] { std::lock_guard<std::mutex> wait(hold); });
  const std::set<std::thread::id> threads = LoopThreads(32);
  held.unlock();
  ASSERT_EQ(threads.size(), 1u);
  EXPECT_EQ(*threads.begin(), std::this_thread::get_id());
}

}  // namespace
}  // namespace sceneloc
