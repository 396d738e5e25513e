// The I/O thread's side of the wire (server/server_io.cc) through a real server: a reply
// whose client has gone is counted.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>
#include <vector>
#include <zmq.hpp>

#include "proto/wire.h"
#include "tests/server/server_call_support.h"

namespace sceneloc {
namespace {

using test::kTestMapName;
using test::LargeJpeg;
using test::LocaliseFeatures;
using test::LocaliseJpeg;
using test::MustConnect;
using test::ParseReply;
using test::RawExchange;
using test::ReceiveFrames;
using test::SendBurst;
using test::SendFrames;

// A reply whose client has gone is counted (stats: replies_undelivered), and the server
// serves on: the ROUTER is mandatory, so nothing is dropped without a trace.
TEST(ServerDeliveryTest, RepliesToClientsThatLeftAreCounted) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  {
    zmq::context_t context;
    zmq::socket_t gone = SendBurst(&context, server.endpoint, LocaliseJpeg(LargeJpeg(1)), 2);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }  // closed (linger 0) while its requests are being worked on
  auto client = MustConnect(server.endpoint);
  uint64_t undelivered = 0;
  for (const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
       undelivered < 2 && std::chrono::steady_clock::now() < deadline;) {
    auto stats = client->Stats();
    ASSERT_TRUE(stats.ok()) << stats.status().ToString();
    undelivered = stats->replies_undelivered();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(undelivered, 2u);
  auto served = client->Localise(kTestMapName, test::TourFeatures(2));
  ASSERT_TRUE(served.ok()) << served.status().ToString();
}

}  // namespace
}  // namespace sceneloc
