#include "common/util/progress_printer.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <utility>

namespace sceneloc {
namespace {

std::string Duration(double seconds) {
  char text[32];
  const long s = std::lround(seconds);
  if (s < 60) {
    std::snprintf(text, sizeof(text), "%.1f s", seconds);
  } else if (s < 3600) {
    std::snprintf(text, sizeof(text), "%ldm%02lds", s / 60, s % 60);
  } else {
    std::snprintf(text, sizeof(text), "%ldh%02ldm", s / 3600, s / 60 % 60);
  }
  return text;
}

}  // namespace

void ProgressPrinter::operator()(const std::string& stage, size_t done, size_t total) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point now = Clock::now();
  if (stage != stage_) {
    stage_ = stage;
    start_ = now;
    last_ = now;  // the first line after the first interval: a quick stage prints once
  }
  const bool tty = isatty(fileno(stderr));
  const bool finished = done >= total;
  if (!finished &&
      now - last_ < (tty ? std::chrono::milliseconds(100) : std::chrono::seconds(10))) {
    return;
  }
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  char left[64] = "";
  if (finished) {
    std::snprintf(left, sizeof(left), "  in %s", Duration(elapsed).c_str());
  } else if (done > 0 && elapsed > 1) {
    const double remaining =
        elapsed * static_cast<double>(total - done) / static_cast<double>(done);
    std::snprintf(left, sizeof(left), "  %s left", Duration(remaining).c_str());
  }
  std::fprintf(stderr, "%s%s  %-10s %zu/%zu%s%s", tty ? "\r\033[K" : "", prefix_.c_str(),
               stage.c_str(), done, total, left, !tty || finished ? "\n" : "");
}

}  // namespace sceneloc
