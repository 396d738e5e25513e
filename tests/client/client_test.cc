// sceneloc::Client: timeouts, retries on a fresh socket, surviving a server restart.
#include "client/client.h"

#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <zmq.hpp>
#include <zmq_addon.hpp>

#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

// A server that never answers: each attempt times out, and each retry arrives as a new
// request on a fresh connection, after which the call fails with IoError.
TEST(ClientTest, TimesOutAndRetriesOnAFreshSocket) {
  zmq::context_t context;
  zmq::socket_t silent(context, zmq::socket_type::router);
  silent.set(zmq::sockopt::linger, 0);
  silent.bind("tcp://127.0.0.1:*");
  ClientOptions options;
  options.timeout_ms = 150;
  options.retries = 1;
  auto client = Client::Connect(silent.get(zmq::sockopt::last_endpoint), options);
  ASSERT_TRUE(client.ok());
  auto reply = (*client)->Stats();
  EXPECT_EQ(reply.status().code(), StatusCode::kIoError);
  EXPECT_NE(reply.status().message().find("2 attempts"), std::string::npos);
  EXPECT_EQ((*client)->retries(), 1);

  std::vector<std::string> identities;
  std::vector<uint64_t> ids;
  for (int n = 0; n < 2; ++n) {
    zmq::pollitem_t item{silent.handle(), 0, ZMQ_POLLIN, 0};
    ASSERT_GT(zmq::poll(&item, 1, std::chrono::seconds(5)), 0);
    std::vector<zmq::message_t> parts;
    ASSERT_TRUE(zmq::recv_multipart(silent, std::back_inserter(parts)));
    ASSERT_EQ(parts.size(), 3u);  // identity, empty delimiter, request
    EXPECT_EQ(parts[1].size(), 0u);
    v1::Request request;
    ASSERT_TRUE(request.ParseFromArray(parts[2].data(), static_cast<int>(parts[2].size())));
    EXPECT_TRUE(request.has_stats());
    identities.push_back(parts[0].to_string());
    ids.push_back(request.request_id());
  }
  EXPECT_NE(identities[0], identities[1]);  // the retry came from a new socket
  EXPECT_EQ(ids[0], ids[1]);                // carrying the same request
}

// A server on a real ROUTER socket that answers its first `overloaded` requests OVERLOADED
// with a retry hint of `hint_ms`, and the rest OK (an empty stats reply), until `requests`
// came or none came for `quiet`. Returns the time each request arrived.
std::vector<std::chrono::steady_clock::time_point> ServeOverloaded(
    zmq::socket_t* router, int requests, int overloaded, uint32_t hint_ms,
    std::chrono::milliseconds quiet = std::chrono::seconds(5),
    v1::StatusCode refusal = v1::OVERLOADED) {
  std::vector<std::chrono::steady_clock::time_point> arrivals;
  for (int n = 0; n < requests; ++n) {
    zmq::pollitem_t item{router->handle(), 0, ZMQ_POLLIN, 0};
    if (zmq::poll(&item, 1, quiet) == 0) break;
    std::vector<zmq::message_t> parts;
    if (!zmq::recv_multipart(*router, std::back_inserter(parts)) || parts.size() != 3) break;
    arrivals.push_back(std::chrono::steady_clock::now());
    v1::Request request;
    request.ParseFromArray(parts[2].data(), static_cast<int>(parts[2].size()));
    v1::Reply reply;
    reply.set_request_id(request.request_id());
    if (n < overloaded) {
      reply.set_status(refusal);
      reply.set_error("test refusal");
      if (refusal == v1::OVERLOADED) reply.set_retry_after_ms(hint_ms);
    } else {
      reply.mutable_stats();
    }
    router->send(parts[0], zmq::send_flags::sndmore);
    router->send(zmq::message_t(), zmq::send_flags::sndmore);
    router->send(zmq::buffer(reply.SerializeAsString()), zmq::send_flags::none);
  }
  return arrivals;
}

// OVERLOADED is waited out: the call asks again after the server's hint (jittered up to
// 1.5x) and returns the answer that follows; the retries are counted.
TEST(ClientTest, WaitsOutOverloadedRepliesAfterTheHint) {
  zmq::context_t context;
  zmq::socket_t router(context, zmq::socket_type::router);
  router.set(zmq::sockopt::linger, 0);
  router.bind("tcp://127.0.0.1:*");
  auto server = std::async(std::launch::async, [&] { return ServeOverloaded(&router, 3, 2, 60); });
  auto client = Client::Connect(router.get(zmq::sockopt::last_endpoint));
  ASSERT_TRUE(client.ok());
  auto reply = (*client)->Stats();
  ASSERT_TRUE(reply.ok()) << reply.status().ToString();
  EXPECT_EQ((*client)->overload_retries(), 2);
  const auto arrivals = server.get();
  ASSERT_EQ(arrivals.size(), 3u);
  for (size_t i = 1; i < arrivals.size(); ++i) {
    const double gap_ms =
        std::chrono::duration<double, std::milli>(arrivals[i] - arrivals[i - 1]).count();
    EXPECT_GE(gap_ms, 59.0) << "retry " << i << " came before the hint";
  }
}

// The time spent waiting is bounded by overload_wait_ms: when the next wait would pass it,
// the OVERLOADED reply is the answer (kResourceExhausted, naming the status); with 0, the
// first one is.
TEST(ClientTest, OverloadWaitIsBounded) {
  for (const int budget_ms : {0, 250}) {
    zmq::context_t context;
    zmq::socket_t router(context, zmq::socket_type::router);
    router.set(zmq::sockopt::linger, 0);
    router.bind("tcp://127.0.0.1:*");
    // Hints of 200 ms: with 250 ms allowed, one retry fits (200-300 ms) at most.
    auto server = std::async(std::launch::async, [&] {
      return ServeOverloaded(&router, 3, 3, 200, std::chrono::milliseconds(600));
    });
    ClientOptions options;
    options.overload_wait_ms = budget_ms;
    auto client = Client::Connect(router.get(zmq::sockopt::last_endpoint), options);
    ASSERT_TRUE(client.ok());
    const auto start = std::chrono::steady_clock::now();
    auto reply = (*client)->Stats();
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(reply.status().code(), StatusCode::kResourceExhausted) << budget_ms;
    EXPECT_EQ(reply.status().message().rfind("OVERLOADED: ", 0), 0u) << reply.status().message();
    EXPECT_LE((*client)->overload_retries(), budget_ms == 0 ? 0 : 1);
    EXPECT_LT(ms, budget_ms + 150.0);
    EXPECT_EQ(server.get().size(), static_cast<size_t>(1 + (*client)->overload_retries()));
  }
  ClientOptions negative;
  negative.overload_wait_ms = -1;
  EXPECT_EQ(Client::Connect("tcp://127.0.0.1:1", negative).status().code(),
            StatusCode::kInvalidArgument);
}

// UNAVAILABLE (a server shutting down: behind a broker, one worker of several) is retried
// on a fresh socket, within options.retries, and the answer that follows is returned.
TEST(ClientTest, RetriesUnavailableOnAFreshSocket) {
  zmq::context_t context;
  zmq::socket_t router(context, zmq::socket_type::router);
  router.set(zmq::sockopt::linger, 0);
  router.bind("tcp://127.0.0.1:*");
  auto server = std::async(std::launch::async, [&] {
    return ServeOverloaded(&router, 2, 1, 0, std::chrono::seconds(5), v1::UNAVAILABLE);
  });
  auto client = Client::Connect(router.get(zmq::sockopt::last_endpoint));
  ASSERT_TRUE(client.ok());
  auto reply = (*client)->Stats();
  ASSERT_TRUE(reply.ok()) << reply.status().ToString();
  EXPECT_EQ(server.get().size(), 2u);
  EXPECT_EQ((*client)->overload_retries(), 0);
  EXPECT_EQ((*client)->retries(), 1);
}

// Invalid options are refused before anything connects.
TEST(ClientTest, RefusesInvalidOptions) {
  ClientOptions options;
  options.timeout_ms = 0;
  EXPECT_EQ(Client::Connect("tcp://127.0.0.1:1", options).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(Client::Connect("not an endpoint").status().code(), StatusCode::kInvalidArgument);
}

// A call made while the server is down completes once a new server comes up on the
// same endpoint (a restart), and later calls keep working.
TEST(ClientTest, SurvivesAServerRestart) {
  const ServerOptions options = test::TestServerOptions();
  test::TestServer first = test::StartTestServer(options);
  ASSERT_NE(first.server, nullptr);
  ClientOptions client_options;
  client_options.timeout_ms = 300;
  client_options.retries = 30;
  auto client = Client::Connect(first.endpoint, client_options);
  ASSERT_TRUE(client.ok());
  ASSERT_TRUE((*client)->ListMaps().ok());
  first.server->Shutdown();
  // Destroying the server terminates its ZeroMQ context, which waits until the listening
  // socket is closed: the port is free before the second server binds it (Shutdown alone
  // leaves the close to ZeroMQ's background thread, and an immediate rebind can race it).
  const std::string endpoint = first.endpoint;
  first.server.reset();

  auto pending = std::async(std::launch::async, [&] {
    return (*client)->Localise(test::kTestMapName, test::TourFeatures(9));
  });
  ServerOptions again = options;
  again.endpoint = endpoint;  // the same port
  test::TestServer second = test::StartTestServer(again);
  ASSERT_NE(second.server, nullptr);
  auto reply = pending.get();
  ASSERT_TRUE(reply.ok()) << reply.status().ToString();
  EXPECT_EQ(reply->locations(0).index(), 9);
  EXPECT_TRUE((*client)->Stats().ok());
}

// An error reply becomes a status naming the wire status, with the nearest engine code.
TEST(ClientTest, ErrorRepliesBecomeStatuses) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  auto client = Client::Connect(server.endpoint);
  ASSERT_TRUE(client.ok());
  auto reply = (*client)->Localise("elsewhere", test::TourJpegs()[0]);
  EXPECT_EQ(reply.status().code(), StatusCode::kNotFound);
  EXPECT_EQ(reply.status().message().rfind("NOT_FOUND: ", 0), 0u) << reply.status().message();
}

}  // namespace
}  // namespace sceneloc
