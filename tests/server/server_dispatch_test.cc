// How the I/O thread routes a request (server/server_dispatch.cc) through a real server:
// stats and list_maps answered inline even while every worker is busy, reload_map handed
// to the map loader, localise queued for the workers or refused OVERLOADED when the queue
// is full, an unknown map NOT_FOUND, and refusals before parsing that keep the request id.
#include <gtest/gtest.h>

#include <optional>
#include <set>
#include <zmq.hpp>

#include "tests/server/server_call_support.h"

namespace sceneloc {
namespace {

using test::AwaitRequests;
using test::CollectReplies;
using test::kTestMapName;
using test::kTestTourLocations;
using test::LocaliseFeatures;
using test::LocaliseJpeg;
using test::MustConnect;
using test::RawCall;
using test::SendBurst;
using test::ServerTest;

// A map name the server does not serve gets NOT_FOUND.
TEST_F(ServerTest, UnknownMapIsNotFound) {
  v1::Request request = LocaliseFeatures(test::TourFeatures(0));
  request.mutable_localise()->set_map("no_such_map");
  auto reply = client_->Call(request);
  ASSERT_TRUE(reply.ok());
  EXPECT_EQ(reply->status(), v1::NOT_FOUND);
  EXPECT_NE(reply->error().find("no_such_map"), std::string::npos);
  EXPECT_FALSE(reply->has_localise());
}

// ListMaps names the map with its generation, checksum and size.
TEST_F(ServerTest, ListMapsShowsTheLoadedMap) {
  auto maps = client_->ListMaps();
  ASSERT_TRUE(maps.ok());
  ASSERT_EQ(maps->maps_size(), 1);
  EXPECT_EQ(maps->maps(0).version().name(), kTestMapName);
  EXPECT_EQ(maps->maps(0).version().generation(), 1u);
  EXPECT_EQ(maps->maps(0).num_locations(), kTestTourLocations);
  EXPECT_GT(maps->maps(0).num_landmarks(), 100);
  EXPECT_GT(maps->maps(0).memory_bytes(), 0u);
}

// ReloadMap reloads the file: a new generation, the same checksum; later answers name it.
TEST_F(ServerTest, ReloadMapBumpsTheGeneration) {
  auto reloaded = client_->Reload(kTestMapName);
  ASSERT_TRUE(reloaded.ok()) << reloaded.status().ToString();
  EXPECT_EQ(reloaded->map().version().generation(), 2u);
  auto reply = client_->Localise(kTestMapName, test::TourFeatures(1));
  ASSERT_TRUE(reply.ok());
  EXPECT_EQ(reply->map().generation(), 2u);
  auto missing = client_->Reload("../etc/passwd");
  EXPECT_EQ(missing.status().code(), StatusCode::kInvalidArgument);
  auto absent = client_->Reload("absent");
  EXPECT_EQ(absent.status().code(), StatusCode::kNotFound);
}

// A server with one worker and a queue of one, flooded: every request gets exactly one
// reply, some OVERLOADED, none dropped.
TEST(ServerOverloadTest, FullQueueRepliesOverloadedNeverDrops) {
  ServerOptions options = test::TestServerOptions();
  options.threads = 1;
  options.queue_capacity = 1;
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);

  zmq::context_t context;
  constexpr int kRequests = 24;
  zmq::socket_t socket =
      SendBurst(&context, server.endpoint, LocaliseFeatures(test::TourFeatures(4)), kRequests);
  int ok = 0, overloaded = 0;
  const std::set<uint64_t> ids = CollectReplies(&socket, kRequests, [&](const v1::Reply& reply) {
    if (reply.status() == v1::OK) {
      ++ok;
      EXPECT_EQ(reply.localise().locations(0).index(), 4);
    } else {
      EXPECT_EQ(reply.status(), v1::OVERLOADED) << reply.error();
      ++overloaded;
    }
  });
  EXPECT_EQ(static_cast<int>(ids.size()), kRequests);
  EXPECT_GE(ok, 1);
  EXPECT_GE(overloaded, 1);
  EXPECT_EQ(ok + overloaded, kRequests);
}

// 900 reload_map requests at once: every one gets exactly one reply, OK (coalesced loads)
// or OVERLOADED, in seconds rather than a backlog of 900 loads; a well-behaved client is
// served meanwhile, and the server shuts down promptly afterwards. (900 stays under
// ZeroMQ's default high-water mark of 1,000 messages: a client that sends more than that
// without reading loses the replies beyond it, by ZeroMQ's design.)
TEST(ServerOverloadTest, ReloadFloodIsCoalescedAndBounded) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  zmq::context_t context;
  constexpr int kRequests = 900;
  v1::Request reload;
  reload.mutable_reload_map()->set_map(kTestMapName);
  const auto start = std::chrono::steady_clock::now();
  zmq::socket_t socket = SendBurst(&context, server.endpoint, reload, kRequests);
  auto good = MustConnect(server.endpoint);
  ASSERT_NE(good, nullptr);
  auto served = good->Localise(kTestMapName, test::TourFeatures(5));
  ASSERT_TRUE(served.ok()) << served.status().ToString();
  int ok = 0, overloaded = 0;
  const std::set<uint64_t> ids = CollectReplies(&socket, kRequests, [&](const v1::Reply& reply) {
    if (reply.status() == v1::OK) {
      ++ok;
    } else {
      EXPECT_EQ(reply.status(), v1::OVERLOADED) << reply.error();
      ++overloaded;
    }
  });
  EXPECT_EQ(static_cast<int>(ids.size()), kRequests);
  EXPECT_GE(ok, 1);
  EXPECT_GE(overloaded, kRequests / 2);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(30));
  const auto stopping = std::chrono::steady_clock::now();
  server.server->Shutdown();
  EXPECT_LT(std::chrono::steady_clock::now() - stopping, std::chrono::seconds(10));
}

// stats and list_maps are answered on the I/O thread, not queued behind localise work:
// with the one worker busy and JPEG requests waiting, a stats reply still counts them in
// flight (a stats request queued behind them would find them all answered).
TEST(ServerDispatchTest, CheapRequestsAreAnsweredWhileTheWorkersAreBusy) {
  ServerOptions options = test::OneWorkerOptions();
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  constexpr int kRequests = 6;
  test::Burst burst(server.endpoint, LocaliseJpeg(test::TourJpegs()[4]), kRequests);
  auto client = MustConnect(server.endpoint);
  ASSERT_NE(client, nullptr);
  // Once the server has read the whole burst, a stats reply counts what is still queued
  // or running, and itself.
  const std::optional<v1::StatsReply> stats = AwaitRequests(client.get(), kRequests);
  ASSERT_TRUE(stats.has_value());
  EXPECT_GE(stats->in_flight(), 2u);
  auto maps = client->ListMaps();
  ASSERT_TRUE(maps.ok()) << maps.status().ToString();
  EXPECT_EQ(maps->maps_size(), 1);
  // The burst is answered too (or refused, if the one worker fell far behind).
  EXPECT_EQ(burst.CountOkOr(v1::OVERLOADED, "").ids.size(), static_cast<size_t>(kRequests));
}

// A request refused before it is parsed keeps the request id at the front of its bytes:
// one over limits.max_message_bytes (RESOURCE_EXHAUSTED, naming the limit) and one whose
// bytes are not a Request (INVALID_ARGUMENT).
TEST(ServerDispatchTest, RefusalsBeforeParsingKeepTheRequestId) {
  ServerOptions options = test::TestServerOptions();
  options.limits.max_message_bytes = 4096;
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  // Over the limit but under twice it (ZMQ_MAXMSGSIZE), so ZeroMQ passes it on.
  v1::Request oversized = LocaliseJpeg(std::string(6000, 'x'));
  oversized.set_request_id(300);
  v1::Reply reply = RawCall(server.endpoint, {"", oversized.SerializeAsString()});
  EXPECT_EQ(reply.status(), v1::RESOURCE_EXHAUSTED) << reply.error();
  EXPECT_EQ(reply.request_id(), 300u);
  EXPECT_NE(reply.error().find("bytes; at most 4096 are accepted"), std::string::npos)
      << reply.error();

  // Field 1 (request_id) = 42, then bytes that no Request parses from.
  reply = RawCall(server.endpoint, {"", std::string("\x08\x2a\xff\xff\xff", 5)});
  EXPECT_EQ(reply.status(), v1::INVALID_ARGUMENT) << reply.error();
  EXPECT_EQ(reply.request_id(), 42u);
  EXPECT_NE(reply.error().find("not a valid sceneloc.v1.Request"), std::string::npos)
      << reply.error();
}

// A feature set of more keypoints than limits.max_keypoints, in a request large enough to
// be parsed on a worker, is refused from a count of its bytes (the parse would allocate a
// message for each of its 200,000 empty keypoints), keeping its request id; the server
// answers the next request as before.
TEST(ServerDispatchTest, TooManyKeypointsAreRefusedBeforeTheParse) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  v1::Request request;
  request.set_request_id(77);
  request.mutable_localise()->set_map("synthetic");
  v1::FeatureSet* features = request.mutable_localise()->mutable_features();
  features->set_image_width(320);
  features->set_image_height(180);
  for (int i = 0; i < 200'000; ++i) features->add_keypoints();
  const std::string bytes = request.SerializeAsString();
  ASSERT_GT(bytes.size(), 64u << 10);  // parsed on a worker, not the I/O thread
  const v1::Reply reply = RawCall(server.endpoint, {"", bytes});
  EXPECT_EQ(reply.status(), v1::RESOURCE_EXHAUSTED) << reply.error();
  EXPECT_EQ(reply.request_id(), 77u);
  EXPECT_NE(reply.error().find("200000 keypoints; at most 8192"), std::string::npos)
      << reply.error();
  EXPECT_NE(reply.error().find("counted before parsing"), std::string::npos) << reply.error();
  v1::Request list;
  list.set_request_id(78);
  list.mutable_list_maps();
  EXPECT_EQ(RawCall(server.endpoint, {"", list.SerializeAsString()}).status(), v1::OK);
}

}  // namespace
}  // namespace sceneloc
