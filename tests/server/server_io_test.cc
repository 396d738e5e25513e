// The I/O thread's side of the wire (server/server_io.cc) through a real server: a reply
// mirrors its request's framing, a request in the wrong frames is refused without the
// connection falling out of step, and a reply whose client has gone is counted.
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

v1::Request StatsRequest(uint64_t id) {
  v1::Request request;
  request.set_request_id(id);
  request.mutable_stats();
  return request;
}

// A request framed [empty][Request] (as REQ sends) is answered [empty][Reply], one framed
// [Request] alone is answered [Reply], whether the I/O thread or a worker answers it; each
// reply carries its request id and this server's protocol.
TEST(ServerIoTest, RepliesMirrorTheRequestsFraming) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  const std::vector<std::string> delimited =
      RawExchange(server.endpoint, {"", StatsRequest(11).SerializeAsString()});
  ASSERT_EQ(delimited.size(), 2u);
  EXPECT_TRUE(delimited[0].empty());
  v1::Reply reply = ParseReply(delimited);
  EXPECT_EQ(reply.status(), v1::OK) << reply.error();
  EXPECT_EQ(reply.request_id(), 11u);
  EXPECT_EQ(reply.protocol(), kProtocolVersion);
  EXPECT_TRUE(reply.has_stats());

  const std::vector<std::string> bare =
      RawExchange(server.endpoint, {StatsRequest(12).SerializeAsString()});
  ASSERT_EQ(bare.size(), 1u);
  reply = ParseReply(bare);
  EXPECT_EQ(reply.request_id(), 12u);
  EXPECT_TRUE(reply.has_stats());

  v1::Request localise = LocaliseFeatures(test::TourFeatures(6));
  localise.set_request_id(13);
  const std::vector<std::string> worked =
      RawExchange(server.endpoint, {localise.SerializeAsString()});
  ASSERT_EQ(worked.size(), 1u);
  reply = ParseReply(worked);
  ASSERT_EQ(reply.status(), v1::OK) << reply.error();
  EXPECT_EQ(reply.request_id(), 13u);
  EXPECT_EQ(reply.protocol(), kProtocolVersion);
  EXPECT_EQ(reply.localise().locations(0).index(), 6);
}

// Requests in the wrong frames get INVALID_ARGUMENT saying how many frames came: too many
// (the extra frames are read and dropped) and three without the empty delimiter; the
// connection stays in step, its next request answered as itself.
TEST(ServerIoTest, MisframedRequestsAreRefusedAndTheConnectionStaysInStep) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  zmq::context_t context;
  zmq::socket_t socket(context, zmq::socket_type::dealer);
  socket.set(zmq::sockopt::linger, 0);
  socket.connect(server.endpoint);
  SendFrames(&socket, {"", StatsRequest(21).SerializeAsString(), "x", "y"});
  SendFrames(&socket, {"x", StatsRequest(22).SerializeAsString()});
  SendFrames(&socket, {"", StatsRequest(23).SerializeAsString()});

  v1::Reply reply = ParseReply(ReceiveFrames(&socket));
  EXPECT_EQ(reply.status(), v1::INVALID_ARGUMENT);
  EXPECT_NE(reply.error().find("got 4 frames after the identity"), std::string::npos)
      << reply.error();
  reply = ParseReply(ReceiveFrames(&socket));
  EXPECT_EQ(reply.status(), v1::INVALID_ARGUMENT);
  EXPECT_NE(reply.error().find("got 2 frames after the identity"), std::string::npos)
      << reply.error();
  reply = ParseReply(ReceiveFrames(&socket));
  EXPECT_EQ(reply.status(), v1::OK) << reply.error();
  EXPECT_EQ(reply.request_id(), 23u);
  EXPECT_TRUE(reply.has_stats());
}

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
