// The operator endpoint over real HTTP on loopback: Prometheus metrics that count what a
// real server did, the liveness and readiness probes following its state (maps, shutdown,
// a worker's broker), and the errors an operator can cause (a taken port, a bad address).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>

#include "client/client.h"
#include "server/broker.h"
#include "server/health.h"
#include "server/http_endpoint.h"
#include "tests/server/http_test_client.h"
#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

using test::Http;
using test::HttpResult;
using test::kTestMapName;

HttpResult Get(const Server& server, const std::string& path) {
  return Http(server.metrics_endpoint(), "GET", path);
}

ServerOptions WithMetrics(ServerOptions options) {
  options.metrics_endpoint = "127.0.0.1:0";
  return options;
}

std::unique_ptr<Client> ClientOf(const std::string& endpoint) {
  auto client = Client::Connect(endpoint);
  EXPECT_TRUE(client.ok()) << client.status().ToString();
  return client.ok() ? std::move(client).value() : nullptr;
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(OperatorEndpointTest, MetricsCountWhatTheServerDid) {
  test::TestServer s = test::StartTestServer(WithMetrics(test::TestServerOptions()));
  ASSERT_NE(s.server, nullptr);
  auto client = ClientOf(s.endpoint);
  ASSERT_NE(client, nullptr);
  ASSERT_TRUE(client->Localise(kTestMapName, test::TourJpegs()[3]).ok());
  ASSERT_TRUE(client->Localise(kTestMapName, test::TourFeatures(4)).ok());
  EXPECT_EQ(client->Localise("made-up-name", test::TourFeatures(4)).status().code(),
            StatusCode::kNotFound);
  ASSERT_TRUE(client->Stats().ok());

  const HttpResult metrics = Get(*s.server, "/metrics");
  ASSERT_EQ(metrics.status, 200) << metrics.body;
  EXPECT_TRUE(Contains(metrics.headers, "text/plain; version=0.0.4")) << metrics.headers;
  const std::string& text = metrics.body;
  EXPECT_TRUE(Contains(
      text, "sceneloc_requests_total{kind=\"localise\",map=\"synthetic\",status=\"OK\"} 2"))
      << text;
  // A map that is not loaded is counted under "": a client cannot add series by names.
  EXPECT_TRUE(
      Contains(text, "sceneloc_requests_total{kind=\"localise\",map=\"\",status=\"NOT_FOUND\"} 1"));
  EXPECT_FALSE(Contains(text, "made-up-name"));
  EXPECT_TRUE(Contains(text, "sceneloc_requests_total{kind=\"stats\",map=\"\",status=\"OK\"} 1"));
  EXPECT_TRUE(Contains(text, "sceneloc_request_duration_seconds_count{kind=\"localise\"} 3"));
  // Decode and extraction ran for the JPEG only; scoring for both.
  EXPECT_TRUE(Contains(text, "sceneloc_stage_duration_seconds_count{stage=\"decode\"} 1"));
  EXPECT_TRUE(Contains(text, "sceneloc_stage_duration_seconds_count{stage=\"descriptor\"} 2"));
  EXPECT_TRUE(Contains(text, "sceneloc_maps_loaded 1"));
  EXPECT_TRUE(Contains(text, "sceneloc_map_generation{map=\"synthetic\"} 1"));
  EXPECT_TRUE(Contains(text, "sceneloc_map_locations{map=\"synthetic\"} " +
                                 std::to_string(test::kTestTourLocations)));
  EXPECT_TRUE(Contains(text, "sceneloc_map_load_failures_total 0"));
  EXPECT_TRUE(Contains(text, "sceneloc_workers 2"));
  EXPECT_TRUE(Contains(text, "sceneloc_queue_depth 0"));
}

// The Grafana dashboard (deploy/grafana) against what a real server exports: every metric
// any panel, query or variable names is in /metrics, every label a panel groups by is on
// that metric, and every panel has a query.
TEST(OperatorEndpointTest, TheDashboardReadsExportedMetrics) {
  test::TestServer s = test::StartTestServer(WithMetrics(test::TestServerOptions()));
  ASSERT_NE(s.server, nullptr);
  auto client = ClientOf(s.endpoint);
  ASSERT_NE(client, nullptr);
  ASSERT_TRUE(client->Localise(kTestMapName, test::TourJpegs()[3]).ok());  // every stage runs
  const HttpResult metrics = Get(*s.server, "/metrics");
  ASSERT_EQ(metrics.status, 200);
  // Each exported series' name, with the labels it carries.
  std::map<std::string, std::set<std::string>> exported;
  const std::regex series(R"(^(sceneloc_[a-z_]+)(\{([^}]*)\})? )");
  const std::regex label(R"(([a-z_]+)=")");
  std::istringstream lines(metrics.body);
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (!std::regex_search(line, m, series)) continue;
    std::set<std::string>& labels = exported[m[1]];
    const std::string inside = m[3];
    for (auto it = std::sregex_iterator(inside.begin(), inside.end(), label);
         it != std::sregex_iterator(); ++it) {
      labels.insert((*it)[1]);
    }
  }
  std::ifstream file(SCENELOC_DEPLOY_DIR "/grafana/sceneloc-dashboard.json");
  ASSERT_TRUE(file.good());
  const nlohmann::json dashboard = nlohmann::json::parse(file);
  ASSERT_GE(dashboard["panels"].size(), 10u);
  const std::regex name(R"(sceneloc_[a-z_]+)");
  const std::regex grouped(R"(by \(([a-z_, ]+)\) \(([^(]*\()*\s*(sceneloc_[a-z_]+))");
  for (const nlohmann::json& panel : dashboard["panels"]) {
    const std::string title = panel["title"];
    ASSERT_FALSE(panel["targets"].empty()) << title;
    for (const nlohmann::json& target : panel["targets"]) {
      const std::string expr = target["expr"];
      int named = 0;
      for (auto it = std::sregex_iterator(expr.begin(), expr.end(), name);
           it != std::sregex_iterator(); ++it, ++named) {
        EXPECT_TRUE(exported.count(it->str())) << title << ": " << it->str() << " in " << expr;
      }
      EXPECT_GT(named, 0) << title << ": " << expr;
      std::smatch by;
      if (std::regex_search(expr, by, grouped) && exported.count(by[3])) {
        std::istringstream names(by[1]);
        for (std::string l; std::getline(names, l, ',');) {
          l.erase(0, l.find_first_not_of(' '));
          if (l == "le") continue;
          EXPECT_TRUE(exported[by[3]].count(l)) << title << ": " << by[3] << " has no " << l;
        }
      }
    }
  }
  // The variables' queries too.
  const std::string text = dashboard["templating"].dump();
  for (auto it = std::sregex_iterator(text.begin(), text.end(), name); it != std::sregex_iterator();
       ++it) {
    EXPECT_TRUE(exported.count(it->str())) << it->str();
  }
}

TEST(OperatorEndpointTest, SessionsAreCounted) {
  test::TestServer s = test::StartTestServer(WithMetrics(test::TestServerOptions()));
  ASSERT_NE(s.server, nullptr);
  auto client = ClientOf(s.endpoint);
  ASSERT_NE(client, nullptr);
  LocaliseOptions options;
  for (const char* robot : {"robot-1", "robot-2"}) {
    options.session = robot;
    ASSERT_TRUE(client->Localise(kTestMapName, test::TourFeatures(1), options).ok());
  }
  EXPECT_TRUE(Contains(Get(*s.server, "/metrics").body, "sceneloc_sessions 2"));
}

TEST(OperatorEndpointTest, ReadyWithAMapAndNotWithout) {
  test::TestServer s = test::StartTestServer(WithMetrics(test::TestServerOptions()));
  ASSERT_NE(s.server, nullptr);
  EXPECT_EQ(Get(*s.server, "/healthz").status, 200);
  const HttpResult ready = Get(*s.server, "/readyz");
  EXPECT_EQ(ready.status, 200) << ready.body;
  EXPECT_TRUE(Contains(ready.body, "1 map(s) loaded"));

  const std::string empty = ::testing::TempDir() + "/sceneloc_no_maps";
  std::filesystem::create_directories(empty);
  ServerOptions options = WithMetrics(test::TestServerOptions());
  options.maps_dir = empty;
  test::TestServer bare = test::StartTestServerOnDir(options);
  ASSERT_NE(bare.server, nullptr);
  EXPECT_EQ(Get(*bare.server, "/healthz").status, 200);  // alive: nothing to restart for
  const HttpResult not_ready = Get(*bare.server, "/readyz");
  EXPECT_EQ(not_ready.status, 503);
  EXPECT_TRUE(Contains(not_ready.body, "no map loaded")) << not_ready.body;
}

// A worker whose broker is down is alive but not ready; it becomes ready once the broker
// comes up at that address (ZeroMQ reconnects by itself).
TEST(OperatorEndpointTest, AWorkerIsReadyOnlyWithItsBroker) {
  BrokerOptions broker_options;
  broker_options.frontend = "tcp://127.0.0.1:*";
  broker_options.backend = "tcp://127.0.0.1:*";
  auto first = Broker::Start(broker_options);
  ASSERT_TRUE(first.ok()) << first.status().ToString();
  broker_options.backend = (*first)->backend();  // a port known to be free once it stops
  (*first)->Stop();
  first->reset();

  ServerOptions options = WithMetrics(test::TestServerOptions());
  options.connect = broker_options.backend;
  test::TestServer worker = test::StartTestServer(options);
  ASSERT_NE(worker.server, nullptr);
  EXPECT_EQ(Get(*worker.server, "/healthz").status, 200);
  const HttpResult waiting = Get(*worker.server, "/readyz");
  EXPECT_EQ(waiting.status, 503);
  EXPECT_TRUE(Contains(waiting.body, "not connected to the broker at " + options.connect))
      << waiting.body;

  auto broker = Broker::Start(broker_options);
  ASSERT_TRUE(broker.ok()) << broker.status().ToString();
  int status = 0;
  for (int i = 0; i < 100 * test::kTimeScale && status != 200; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    status = Get(*worker.server, "/readyz").status;
  }
  EXPECT_EQ(status, 200);
  auto client = ClientOf((*broker)->frontend());
  ASSERT_NE(client, nullptr);
  EXPECT_TRUE(client->Localise(kTestMapName, test::TourFeatures(2)).ok());
}

TEST(OperatorEndpointTest, ATakenPortIsAClearError) {
  test::TestServer s = test::StartTestServer(WithMetrics(test::TestServerOptions()));
  ASSERT_NE(s.server, nullptr);
  ServerOptions options = test::TestServerOptions();
  options.metrics_endpoint = s.server->metrics_endpoint();
  auto registry = std::make_unique<MapRegistry>(MapRegistry::Options{});
  auto second = Server::Start(options, registry.get());
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.status().code(), StatusCode::kIoError);
  EXPECT_TRUE(Contains(second.status().message(), options.metrics_endpoint))
      << second.status().message();
  EXPECT_EQ(Get(*s.server, "/healthz").status, 200);  // the first one is untouched
}

TEST(OperatorEndpointTest, AMalformedAddressIsRefusedWithTheSettingsName) {
  for (const char* bad : {"9464", "localhost:", "127.0.0.1:99999", "127.0.0.1:http", ":-1"}) {
    ServerOptions options = test::TestServerOptions();
    options.metrics_endpoint = bad;
    const Status status = options.Validate();
    EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << bad;
    EXPECT_TRUE(Contains(status.message(), "server.metrics_endpoint")) << status.message();
  }
}

}  // namespace
}  // namespace sceneloc
