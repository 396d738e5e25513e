// Progress of long work on stderr: one line per stage with an estimate of the stage's time
// left, rewritten in place on a terminal (at most ten times a second), else printed every
// ten seconds and at the end (logs of CI and nohup runs stay short).
//
// Not thread-safe: callers serialise their calls (the trainer's ProgressFn calls are).
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace sceneloc {

class ProgressPrinter {
 public:
  // `prefix` starts every line (e.g. a set's name).
  explicit ProgressPrinter(std::string prefix = "") : prefix_(std::move(prefix)) {}

  void operator()(const std::string& stage, size_t done, size_t total);

 private:
  std::string prefix_;
  std::string stage_;
  std::chrono::steady_clock::time_point start_, last_;
};

}  // namespace sceneloc
