// Shutdown and the drain (server/server_shutdown.cc) through a real server: every request
// in flight gets one answer; while the drain lasts, new requests are UNAVAILABLE and the
// admitted ones are worked on; past drain_timeout_s the queued ones are UNAVAILABLE.
#include <gtest/gtest.h>

#include <chrono>
#include <iterator>
#include <set>
#include <thread>
#include <vector>
#include <zmq.hpp>
#include <zmq_addon.hpp>

#include "tests/server/server_call_support.h"

namespace sceneloc {
namespace {

using test::AwaitRequests;
using test::MustConnect;

// Shutdown with requests queued and running: each gets an answer or UNAVAILABLE, and
// Shutdown returns.
TEST(ServerShutdownTest, InFlightRequestsAreAnsweredOnShutdown) {
  ServerOptions options = test::TestServerOptions();
  options.threads = 1;
  options.queue_capacity = 16;
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  zmq::context_t context;
  constexpr int kRequests = 6;
  zmq::socket_t socket = test::SendBurst(&context, server.endpoint,
                                         test::LocaliseFeatures(test::TourFeatures(6)), kRequests);
  // Wait until the server has taken them all in, then stop it.
  auto client = MustConnect(server.endpoint);
  ASSERT_TRUE(AwaitRequests(client.get(), kRequests).has_value());
  server.server->Shutdown();
  int answered = 0;
  for (int n = 0; n < kRequests; ++n) {
    zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
    if (zmq::poll(&item, 1, std::chrono::seconds(5)) == 0) break;
    std::vector<zmq::message_t> parts;
    ASSERT_TRUE(zmq::recv_multipart(socket, std::back_inserter(parts)));
    v1::Reply reply;
    ASSERT_TRUE(reply.ParseFromArray(parts.back().data(), static_cast<int>(parts.back().size())));
    EXPECT_TRUE(reply.status() == v1::OK || reply.status() == v1::UNAVAILABLE) << reply.error();
    ++answered;
  }
  EXPECT_EQ(answered, kRequests);
}

// While the drain lasts (the one worker still on large JPEGs), a new request gets
// UNAVAILABLE at once, and the requests admitted before it are all worked on and answered.
TEST(ServerShutdownTest, DrainRefusesNewRequestsAndFinishesAdmittedOnes) {
  ServerOptions options = test::OneWorkerOptions();
  options.limits.max_queue_wait_ms = 60000;  // no request is too stale to work on
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  constexpr int kRequests = 3;
  test::Burst burst(server.endpoint, test::LocaliseJpeg(test::LargeJpeg(2)), kRequests);
  auto client = MustConnect(server.endpoint, 5000 * test::kTimeScale);
  ASSERT_NE(client, nullptr);
  ASSERT_TRUE(AwaitRequests(client.get(), kRequests).has_value());
  std::thread stopper([&] { server.server->Shutdown(); });
  // Stats is answered inline until the I/O thread has been told to drain.
  v1::Request stats;
  stats.mutable_stats();
  StatusOr<v1::Reply> refused = client->Call(stats);
  for (int n = 0; refused.ok() && refused->status() == v1::OK && n < 100000; ++n) {
    refused = client->Call(stats);
  }
  ASSERT_TRUE(refused.ok()) << refused.status().ToString();
  EXPECT_EQ(refused->status(), v1::UNAVAILABLE) << refused->error();
  EXPECT_NE(refused->error().find("server is shutting down"), std::string::npos)
      << refused->error();
  EXPECT_EQ(burst.CountOkOr(v1::OK, "").ok, kRequests);
  stopper.join();
}

// With drain_timeout_s 0 the drain ends at once: the requests still queued are answered
// UNAVAILABLE without being worked on, each with its own request id (tour JPEGs are over
// 64 KiB, so still unparsed while queued), the one running is answered, and Shutdown may
// be called again.
TEST(ServerShutdownTest, QueuedRequestsPastTheDrainTimeoutAreUnavailable) {
  ServerOptions options = test::OneWorkerOptions();
  options.drain_timeout_s = 0;
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  const v1::Request request = test::LocaliseJpeg(test::TourJpegs()[6]);
  ASSERT_GT(request.ByteSizeLong(), size_t{64} << 10);
  test::Burst burst(server.endpoint, request, 6);
  auto client = MustConnect(server.endpoint);
  ASSERT_NE(client, nullptr);
  ASSERT_TRUE(AwaitRequests(client.get(), 6).has_value());
  server.server->Shutdown();
  server.server->Shutdown();  // idempotent
  const test::Burst::Counts counts =
      burst.CountOkOr(v1::UNAVAILABLE, "shut down before this request was started");
  EXPECT_EQ(counts.ids.size(), 6u);
  EXPECT_GE(counts.refused, 1);
}

}  // namespace
}  // namespace sceneloc
