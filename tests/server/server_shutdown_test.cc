// Shutdown and the drain (server/server_shutdown.cc) through a real server: every request
// in flight gets one answer.
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

}  // namespace
}  // namespace sceneloc
