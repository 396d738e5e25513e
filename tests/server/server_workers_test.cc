// The worker threads (server/server_workers.cc) through a real server: the pool answers
// many clients at once, parses the requests too large for the I/O thread and checks them
// as it would, and does not work on a request that waited too long for it.
#include <gtest/gtest.h>

#include <atomic>
#include <set>
#include <string>
#include <thread>
#include <vector>
#include <zmq.hpp>

#include "proto/wire.h"
#include "tests/server/server_call_support.h"

namespace sceneloc {
namespace {

using test::kTestMapName;
using test::kTestTourLocations;
using test::LargeJpeg;
using test::LocaliseJpeg;
using test::MustConnect;
using test::RawCall;
using test::ServerTest;

// Several clients at once, each on its own thread and socket, all get correct answers.
TEST_F(ServerTest, ConcurrentClientsAllAnsweredCorrectly) {
  constexpr int kClients = 4, kRequests = 4;
  std::atomic<int> correct{0};
  std::vector<std::thread> threads;
  for (int c = 0; c < kClients; ++c) {
    threads.emplace_back([&, c] {
      auto client = MustConnect(server_.endpoint);
      if (client == nullptr) return;
      for (int r = 0; r < kRequests; ++r) {
        const int i = (c * kRequests + r) % kTestTourLocations;
        auto reply = (r % 2 == 0) ? client->Localise(kTestMapName, test::TourFeatures(i))
                                  : client->Localise(kTestMapName, test::TourJpegs()[i]);
        if (reply.ok() && !reply->locations().empty() && reply->locations(0).index() == i) {
          ++correct;
        }
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(correct.load(), kClients * kRequests);
}

// Requests over 64 KiB are parsed by a worker, not the I/O thread: a valid large localise
// request is answered, and a large message that is not one gets INVALID_ARGUMENT saying why.
TEST(ServerFairnessTest, LargeRequestsAreParsedByWorkers) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  v1::Request big_list;
  big_list.set_request_id(41);
  big_list.mutable_list_maps();
  // Field 15 is unknown to ListMapsRequest's parent: a parser keeps it and moves on.
  std::string bytes = big_list.SerializeAsString();
  const std::string padding(100 << 10, 'x');
  bytes += std::string("\x7a", 1);  // field 15, length-delimited
  for (uint64_t n = padding.size();; n >>= 7) {
    if (n < 0x80) {
      bytes += static_cast<char>(n);
      break;
    }
    bytes += static_cast<char>((n & 0x7F) | 0x80);
  }
  bytes += padding;
  v1::Reply reply = RawCall(server.endpoint, {"", bytes});
  EXPECT_EQ(reply.status(), v1::INVALID_ARGUMENT) << reply.error();
  EXPECT_EQ(reply.request_id(), 41u);
  EXPECT_NE(reply.error().find("only localise requests may be larger"), std::string::npos)
      << reply.error();

  reply = RawCall(server.endpoint, {"", std::string(200 << 10, '\xff')});
  EXPECT_EQ(reply.status(), v1::INVALID_ARGUMENT) << reply.error();

  v1::Request large = LocaliseJpeg(LargeJpeg(7));
  large.set_request_id(42);
  ASSERT_GT(large.ByteSizeLong(), size_t{64} << 10);
  reply = RawCall(server.endpoint, {"", large.SerializeAsString()});
  ASSERT_EQ(reply.status(), v1::OK) << reply.error();
  EXPECT_EQ(reply.request_id(), 42u);
  EXPECT_NEAR(reply.localise().locations(0).index(), 7, 1);
}

// A request too large for the I/O thread to parse gets the worker's check of its protocol:
// one of a newer protocol is UNIMPLEMENTED naming both versions, with its request id, and
// not marked retry_elsewhere (this server is no broker's worker).
TEST(ServerWorkersTest, LargeRequestOfANewerProtocolIsRefused) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  v1::Request request = LocaliseJpeg(std::string(100 << 10, 'x'));  // never decoded
  request.set_request_id(43);
  request.set_protocol(kProtocolVersion + 1);
  const v1::Reply reply = RawCall(server.endpoint, {"", request.SerializeAsString()});
  EXPECT_EQ(reply.status(), v1::UNIMPLEMENTED) << reply.error();
  EXPECT_EQ(reply.request_id(), 43u);
  EXPECT_NE(reply.error().find("protocol " + std::to_string(kProtocolVersion + 1) +
                               "; this server speaks " + std::to_string(kProtocolVersion)),
            std::string::npos)
      << reply.error();
  EXPECT_FALSE(reply.retry_elsewhere());
}

// A request that waited for the one worker longer than twice limits.max_queue_wait_ms
// (here 2 x 50 ms, while the worker was on a large JPEG) is answered OVERLOADED without
// being worked on, saying so; the one the worker took at once is answered. (A fresh server
// has no estimate of a request's cost, so it admits the whole burst.)
TEST(ServerWorkersTest, RequestsThatWaitedTooLongAreNotWorkedOn) {
  ServerOptions options = test::OneWorkerOptions();
  options.limits.max_queue_wait_ms = 50;
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  constexpr int kRequests = 3;
  test::Burst burst(server.endpoint, LocaliseJpeg(LargeJpeg(5)), kRequests);
  const test::Burst::Counts counts = burst.CountOkOr(
      v1::OVERLOADED, "more than twice limits.max_queue_wait_ms (50); it was not worked on");
  EXPECT_EQ(static_cast<int>(counts.ids.size()), kRequests);
  EXPECT_GE(counts.ok, 1);
  EXPECT_GE(counts.refused, 1);
}

}  // namespace
}  // namespace sceneloc
