// ServerStats and its latency histogram: counts and percentiles a user reads in Stats.
#include "server/server_stats.h"

#include <gtest/gtest.h>

namespace sceneloc {
namespace {

// Percentiles of 1..1000 ms land within the histogram's 5% resolution.
TEST(LatencyHistogramTest, PercentilesWithinFivePercent) {
  LatencyHistogram h;
  EXPECT_EQ(h.Percentile(0.5), 0.0);
  for (int ms = 1; ms <= 1000; ++ms) h.Add(ms);
  EXPECT_NEAR(h.Percentile(0.50), 500, 25);
  EXPECT_NEAR(h.Percentile(0.90), 900, 45);
  EXPECT_NEAR(h.Percentile(0.99), 990, 50);
  EXPECT_EQ(h.max(), 1000);
  EXPECT_EQ(h.count(), 1000u);
  EXPECT_LE(h.Percentile(1.0), 1000);
}

// Replies are counted by status; only successful localise replies enter the latency.
TEST(ServerStatsTest, CountsRepliesByStatus) {
  ServerStats stats;
  for (int i = 0; i < 4; ++i) stats.RecordRequest();
  stats.RecordReply("OK", true, 10);
  stats.RecordReply("OK", false, 1);
  stats.RecordReply("OVERLOADED", true, 0.1);
  const StatsSnapshot s = stats.Snapshot();
  EXPECT_EQ(s.requests, 4u);
  EXPECT_EQ(s.in_flight, 1u);
  EXPECT_EQ(s.replies_by_status.at("OK"), 2u);
  EXPECT_EQ(s.replies_by_status.at("OVERLOADED"), 1u);
  EXPECT_EQ(s.latency_count, 1u);
  EXPECT_NEAR(s.latency_p50_ms, 10, 0.5);
}

}  // namespace
}  // namespace sceneloc
