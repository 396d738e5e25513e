// The server's counters: requests, replies by status, and a latency histogram for the
// percentiles the Stats reply and the periodic log line show.
//
// Thread-safe: every method may be called from any thread (one mutex; each call holds it
// for a few increments).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "common/util/mutex.h"
#include "common/util/thread_annotations.h"

namespace sceneloc {

// Latencies in log-spaced buckets (5% wide, 0.01 ms .. ~10 min): percentiles within 5%.
class LatencyHistogram {
 public:
  void Add(double ms);
  uint64_t count() const { return count_; }
  double max() const { return max_; }
  // The latency below which a fraction q (0..1) of the samples fall; 0 when empty.
  double Percentile(double q) const;

 private:
  static constexpr int kBuckets = 480;
  std::array<uint64_t, kBuckets> buckets_{};
  uint64_t count_ = 0;
  double max_ = 0;
};

struct StatsSnapshot {
  double uptime_s = 0;
  uint64_t requests = 0;
  uint64_t in_flight = 0;
  std::map<std::string, uint64_t> replies_by_status;  // wire status name -> count
  uint64_t latency_count = 0;                         // successful localise requests
  double latency_p50_ms = 0;
  double latency_p90_ms = 0;
  double latency_p99_ms = 0;
  double latency_max_ms = 0;
  uint64_t replies_undelivered = 0;
};

class ServerStats {
 public:
  ServerStats();
  // A request arrived (of any kind, before any check).
  void RecordRequest() EXCLUDES(mutex_);
  // Its reply left, with this wire status name ("OK", "OVERLOADED", ...). A successful
  // localise request adds its end-to-end latency to the histogram.
  void RecordReply(const std::string& status, bool is_localise, double latency_ms) EXCLUDES(mutex_);
  // A reply could not be delivered (the client had gone or had stopped reading).
  void RecordUndelivered() EXCLUDES(mutex_);
  StatsSnapshot Snapshot() const EXCLUDES(mutex_);

 private:
  // Constant after construction.
  const std::chrono::steady_clock::time_point start_;

  mutable Mutex mutex_;
  // Guarded by mutex_.
  uint64_t requests_ GUARDED_BY(mutex_) = 0;
  uint64_t replies_ GUARDED_BY(mutex_) = 0;
  std::map<std::string, uint64_t> replies_by_status_ GUARDED_BY(mutex_);
  uint64_t undelivered_ GUARDED_BY(mutex_) = 0;
  LatencyHistogram latency_ GUARDED_BY(mutex_);
};

}  // namespace sceneloc
