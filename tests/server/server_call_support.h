// Shared by the server_*_test files: talking to a test server (server_test_support.h) over
// real sockets, as a client or frame by frame, and the requests those tests send.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>
#include <zmq.hpp>

#include "client/client.h"
#include "common/features/feature_set.h"
#include "proto/sceneloc.pb.h"
#include "tests/server/server_test_support.h"

namespace sceneloc::test {

// Sends `frames` as one message on `socket`.
void SendFrames(zmq::socket_t* socket, const std::vector<std::string>& frames);
// The frames of the next message on `socket` (waits up to 20 s; empty, with a test failure,
// when none came).
std::vector<std::string> ReceiveFrames(zmq::socket_t* socket);
// A reply's last frame parsed (a test failure when there is none or it is not a Reply).
v1::Reply ParseReply(const std::vector<std::string>& frames);
// Sends `frames` on a fresh DEALER and returns the frames of the one reply.
std::vector<std::string> RawExchange(const std::string& endpoint,
                                     const std::vector<std::string>& frames);
// RawExchange's reply parsed.
v1::Reply RawCall(const std::string& endpoint, const std::vector<std::string>& frames);

// A client of `endpoint` that does not retry after a timeout (null, with a test failure,
// when it cannot be made).
std::unique_ptr<Client> MustConnect(const std::string& endpoint, int timeout_ms = 20000);

// TestServerOptions() with one worker thread: tests of queueing and admission, where
// requests wait for it.
ServerOptions OneWorkerOptions();

// A localise request for the test map with `features` (float32) or `jpeg`.
v1::Request LocaliseFeatures(const FeatureSet& features);
v1::Request LocaliseJpeg(const std::string& jpeg);

// A JPEG of the test tour's location `i` enlarged to 2400x1350 at quality 95 (~1 MB), so
// that each request is large and takes a worker a while (decoding, resizing, extracting).
std::string LargeJpeg(int i);

// A DEALER socket connected to `endpoint` that has sent `count` copies of `request` back
// to back, with request ids 1..count, without waiting for any reply.
zmq::socket_t SendBurst(zmq::context_t* context, const std::string& endpoint, v1::Request request,
                        int count);

// Reads replies from `socket` until `count` distinct request ids have come (or 60 s have
// passed), expecting no request answered twice; calls `check` on each. Returns the ids.
std::set<uint64_t> CollectReplies(zmq::socket_t* socket, int count,
                                  const std::function<void(const v1::Reply&)>& check);

// `count` copies of a request sent back to back on one DEALER of its own (SendBurst), and
// their replies.
class Burst {
 public:
  Burst(const std::string& endpoint, const v1::Request& request, int count);
  Burst(const Burst&) = delete;
  Burst& operator=(const Burst&) = delete;

  struct Counts {
    int ok = 0;
    int refused = 0;
    std::set<uint64_t> ids;  // of every reply
  };
  // Collects every reply (CollectReplies): each is OK or `refusal` with an error containing
  // `why`; any other reply is a test failure.
  Counts CountOkOr(v1::StatusCode refusal, const std::string& why);

 private:
  const int count_;
  zmq::context_t context_;
  zmq::socket_t socket_;
};

// Calls Stats on `client` until its server has read `count` requests besides these Stats
// calls (Stats counts requests, every Stats call so far included), for up to 20 s. The
// last reply; nullopt, with a test failure, when a call failed or time ran out.
std::optional<v1::StatsReply> AwaitRequests(Client* client, uint64_t count);

// A test server with the default test options and a client of it.
class ServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = StartTestServer(TestServerOptions());
    ASSERT_FALSE(HasFatalFailure());
    ASSERT_NE(server_.server, nullptr);
    client_ = MustConnect(server_.endpoint);
    ASSERT_NE(client_, nullptr);
  }

  TestServer server_;
  std::unique_ptr<Client> client_;
};

}  // namespace sceneloc::test
