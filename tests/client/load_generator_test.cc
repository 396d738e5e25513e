// The load generator: what it counts, against a real server and against none.
#include "client/load_generator.h"

#include <gtest/gtest.h>

#include <zmq.hpp>

#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

// Nearest-rank quantiles, on unsorted input.
TEST(LoadGeneratorTest, QuantileIsNearestRank) {
  const std::vector<double> values = {5, 1, 4, 2, 3, 10, 9, 8, 7, 6};
  EXPECT_EQ(Quantile(values, 0.5), 5);
  EXPECT_EQ(Quantile(values, 0.9), 9);
  EXPECT_EQ(Quantile(values, 0.99), 10);
  EXPECT_EQ(Quantile(values, 0.0), 1);
  EXPECT_EQ(Quantile({}, 0.5), 0);
}

// Options are checked before anything connects; no queries is an error.
TEST(LoadGeneratorTest, RefusesBadOptions) {
  LoadOptions options;
  options.endpoint = "tcp://127.0.0.1:1";
  options.map = "m";
  options.clients = 0;
  EXPECT_EQ(RunLoad(options, {JpegQuery("a", "x")}).status().code(), StatusCode::kInvalidArgument);
  options.clients = 1;
  options.duration_s = 0;
  EXPECT_EQ(RunLoad(options, {JpegQuery("a", "x")}).status().code(), StatusCode::kInvalidArgument);
  options.duration_s = 0.1;
  EXPECT_EQ(RunLoad(options, {}).status().code(), StatusCode::kInvalidArgument);
}

// Feature-set queries against the real server: every request answered OK by generation 1,
// the answers' latencies recorded, and the load stops by itself.
TEST(LoadGeneratorTest, FeatureQueriesAllAnswered) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  LoadOptions options;
  options.endpoint = server.endpoint;
  options.map = test::kTestMapName;
  options.clients = 3;
  options.duration_s = 0.5;
  std::vector<LoadQuery> queries;
  for (int i : {1, 5, 9}) queries.push_back(FeatureQuery("f", test::TourFeatures(i)));
  auto result = RunLoad(options, queries);
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_GT(result->requests, 0);
  EXPECT_EQ(result->ok, result->requests);
  EXPECT_TRUE(result->errors.empty());
  EXPECT_EQ(result->latency_ms.size(), static_cast<size_t>(result->ok));
  ASSERT_EQ(result->map_versions.size(), 1u);
  EXPECT_EQ(result->map_versions.begin()->first, 1u);
  EXPECT_LT(result->elapsed_s, 5.0 * test::kTimeScale);
}

// A server that never answers: each request times out once (no retries) and counts as
// NO_REPLY; nothing is counted as a success.
TEST(LoadGeneratorTest, SilentServerCountsNoReply) {
  zmq::context_t context;
  zmq::socket_t silent(context, zmq::socket_type::router);
  silent.set(zmq::sockopt::linger, 0);
  silent.bind("tcp://127.0.0.1:*");
  LoadOptions options;
  options.endpoint = silent.get(zmq::sockopt::last_endpoint);
  options.map = "m";
  options.clients = 2;
  options.duration_s = 0.1;
  options.timeout_ms = 200;
  auto result = RunLoad(options, {JpegQuery("a", "x")});
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_EQ(result->requests, 2);  // one per client: each blocks past the deadline
  EXPECT_EQ(result->ok, 0);
  EXPECT_EQ(result->errors["NO_REPLY"], 2);
  EXPECT_TRUE(result->latency_ms.empty());
}

}  // namespace
}  // namespace sceneloc
