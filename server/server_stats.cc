#include "server/server_stats.h"

#include <algorithm>
#include <cmath>

namespace sceneloc {
namespace {

constexpr double kFirstBucketMs = 0.01;
constexpr double kGrowth = 1.05;

}  // namespace

void LatencyHistogram::Add(double ms) {
  const double ratio = std::max(ms, kFirstBucketMs) / kFirstBucketMs;
  const int bucket = std::min(kBuckets - 1, static_cast<int>(std::log(ratio) / std::log(kGrowth)));
  ++buckets_[static_cast<size_t>(bucket)];
  ++count_;
  max_ = std::max(max_, ms);
}

double LatencyHistogram::Percentile(double q) const {
  if (count_ == 0) return 0;
  const auto rank = static_cast<uint64_t>(std::ceil(q * static_cast<double>(count_)));
  uint64_t seen = 0;
  for (int i = 0; i < kBuckets; ++i) {
    seen += buckets_[static_cast<size_t>(i)];
    // The bucket's upper edge, never beyond the largest sample.
    if (seen >= std::max<uint64_t>(rank, 1)) {
      return std::min(max_, kFirstBucketMs * std::pow(kGrowth, i + 1));
    }
  }
  return max_;
}

ServerStats::ServerStats() : start_(std::chrono::steady_clock::now()) {}

void ServerStats::RecordRequest() {
  MutexLock lock(&mutex_);
  ++requests_;
}

void ServerStats::RecordReply(const std::string& status, bool is_localise, double latency_ms) {
  MutexLock lock(&mutex_);
  ++replies_;
  ++replies_by_status_[status];
  if (is_localise && status == "OK") latency_.Add(latency_ms);
}

void ServerStats::RecordUndelivered() {
  MutexLock lock(&mutex_);
  ++undelivered_;
}

StatsSnapshot ServerStats::Snapshot() const {
  StatsSnapshot s;
  s.uptime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  MutexLock lock(&mutex_);
  s.requests = requests_;
  s.in_flight = requests_ - replies_;
  s.replies_by_status = replies_by_status_;
  s.latency_count = latency_.count();
  s.latency_p50_ms = latency_.Percentile(0.50);
  s.latency_p90_ms = latency_.Percentile(0.90);
  s.latency_p99_ms = latency_.Percentile(0.99);
  s.latency_max_ms = latency_.max();
  s.replies_undelivered = undelivered_;
  return s;
}

}  // namespace sceneloc
