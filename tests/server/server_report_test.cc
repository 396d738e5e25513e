// What a real server reports about itself (server/server_report.cc): every reply counted
// by status in Stats whichever part gave it, each reply logged at debug, the summary line
// (periodic, and last at shutdown), and the map a reload_map reply is counted under.
#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "tests/server/http_test_client.h"
#include "tests/server/server_call_support.h"

namespace sceneloc {
namespace {

using test::kTestMapName;
using test::MustConnect;
using test::RawCall;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Takes the place of spdlog's default logger (the one the server logs to) for its
// lifetime, keeping what is logged at `level` and above. Make it before the server and end
// it after, so no server thread logs while the logger is swapped.
class LogCapture {
 public:
  explicit LogCapture(spdlog::level::level_enum level)
      : sink_(std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(10000)),
        previous_(spdlog::default_logger()),
        level_(level) {
    spdlog::set_default_logger(std::make_shared<spdlog::logger>("capture", sink_));
  }
  ~LogCapture() { spdlog::set_default_logger(previous_); }
  LogCapture(const LogCapture&) = delete;
  LogCapture& operator=(const LogCapture&) = delete;

  // Sets the level again once the server has started (StartTestServer sets warn).
  void Listen() { spdlog::default_logger()->set_level(level_); }
  // The lines logged so far that contain `part`.
  std::vector<std::string> Lines(const std::string& part) const {
    std::vector<std::string> lines;
    for (const std::string& line : sink_->last_formatted()) {
      if (Contains(line, part)) lines.push_back(line);
    }
    return lines;
  }

 private:
  const std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink_;
  const std::shared_ptr<spdlog::logger> previous_;
  const spdlog::level::level_enum level_;
};

// Every reply is counted by its status, whichever part of the server gave it (the I/O
// thread refusing frames, stats and list_maps answered inline, the workers, the map
// loader), and only successful localise requests enter the latency summary.
TEST(ServerReportTest, StatsCountEveryReplyByStatus) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  auto client = MustConnect(server.endpoint);
  ASSERT_NE(client, nullptr);
  ASSERT_TRUE(client->Localise(kTestMapName, test::TourFeatures(1)).ok());
  ASSERT_TRUE(client->Localise(kTestMapName, test::TourJpegs()[2]).ok());
  EXPECT_EQ(client->Localise("no_such_map", test::TourFeatures(1)).status().code(),
            StatusCode::kNotFound);
  EXPECT_EQ(RawCall(server.endpoint, {"a", "b", "c"}).status(), v1::INVALID_ARGUMENT);
  ASSERT_TRUE(client->ListMaps().ok());
  ASSERT_TRUE(client->Reload(kTestMapName).ok());
  auto stats = client->Stats();
  ASSERT_TRUE(stats.ok()) << stats.status().ToString();
  EXPECT_EQ(stats->requests(), 7u);   // this one included
  EXPECT_EQ(stats->in_flight(), 1u);  // this one
  EXPECT_EQ(stats->replies_by_status_size(), 3);
  EXPECT_EQ(stats->replies_by_status().at("OK"), 4u);
  EXPECT_EQ(stats->replies_by_status().at("NOT_FOUND"), 1u);
  EXPECT_EQ(stats->replies_by_status().at("INVALID_ARGUMENT"), 1u);
  EXPECT_EQ(stats->localise_latency_ms().count(), 2u);
  EXPECT_GT(stats->localise_latency_ms().p50(), 0.0);
  EXPECT_LE(stats->localise_latency_ms().p50(), stats->localise_latency_ms().max());
}

// Each reply is logged at debug with its kind and status (and the error when it is one),
// and Shutdown logs the summary: requests, replies by status, how many latencies, the
// maps served with their generations and the loads.
TEST(ServerReportTest, RepliesAndTheFinalSummaryAreLogged) {
  LogCapture log(spdlog::level::debug);
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  log.Listen();
  auto client = MustConnect(server.endpoint);
  ASSERT_NE(client, nullptr);
  ASSERT_TRUE(client->Localise(kTestMapName, test::TourFeatures(3)).ok());
  ASSERT_TRUE(client->Localise(kTestMapName, test::TourFeatures(4)).ok());
  EXPECT_FALSE(client->Localise("no_such_map", test::TourFeatures(4)).ok());
  server.server->Shutdown();

  EXPECT_EQ(log.Lines("localise: OK in").size(), 2u);
  const std::vector<std::string> not_found = log.Lines("localise: NOT_FOUND in");
  ASSERT_EQ(not_found.size(), 1u);
  EXPECT_TRUE(Contains(not_found[0], "no_such_map")) << not_found[0];
  const std::vector<std::string> summary = log.Lines("summary:");
  ASSERT_EQ(summary.size(), 1u);
  EXPECT_TRUE(Contains(summary[0], "summary: 3 requests, 0 in flight, replies: NOT_FOUND=1 OK=2;"))
      << summary[0];
  EXPECT_TRUE(Contains(summary[0], "(n=2); maps: synthetic@1; map loads 1 ok, 0 failed"))
      << summary[0];
}

// With summary_interval_s set, the summary line comes that often while the server serves.
TEST(ServerReportTest, SummaryLinesFollowTheInterval) {
  LogCapture log(spdlog::level::info);
  ServerOptions options = test::TestServerOptions();
  options.summary_interval_s = 0.05;
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  log.Listen();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (log.Lines("summary:").size() < 2 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  const std::vector<std::string> summary = log.Lines("summary:");
  ASSERT_GE(summary.size(), 2u);
  EXPECT_TRUE(Contains(summary[0], "maps: synthetic@1;")) << summary[0];
}

// A reload_map reply is counted in the metrics under the map it reloaded; one of a map
// that is not loaded under "", so a client cannot add series by naming maps.
TEST(ServerReportTest, ReloadsAreCountedUnderTheirMap) {
  ServerOptions options = test::TestServerOptions();
  options.metrics_endpoint = "127.0.0.1:0";
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  auto client = MustConnect(server.endpoint);
  ASSERT_NE(client, nullptr);
  ASSERT_TRUE(client->Reload(kTestMapName).ok());
  EXPECT_EQ(client->Reload("absent").status().code(), StatusCode::kNotFound);
  const test::HttpResult metrics = test::Http(server.server->metrics_endpoint(), "GET", "/metrics");
  ASSERT_EQ(metrics.status, 200) << metrics.body;
  EXPECT_TRUE(
      Contains(metrics.body,
               "sceneloc_requests_total{kind=\"reload_map\",map=\"synthetic\",status=\"OK\"} 1"))
      << metrics.body;
  EXPECT_TRUE(Contains(
      metrics.body, "sceneloc_requests_total{kind=\"reload_map\",map=\"\",status=\"NOT_FOUND\"} 1"))
      << metrics.body;
  EXPECT_FALSE(Contains(metrics.body, "absent"));
}

}  // namespace
}  // namespace sceneloc
