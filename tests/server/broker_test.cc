// The broker (server/broker.h) with plain ZeroMQ peers: a request from a client reaches a
// worker on the backend and its reply comes back, workers share the requests, and the
// options and endpoints it refuses.
#include "server/broker.h"

#include <gtest/gtest.h>

#include <string>
#include <zmq.hpp>

namespace sceneloc {
namespace {

std::unique_ptr<Broker> StartLocalBroker() {
  BrokerOptions options;
  options.frontend = "tcp://127.0.0.1:*";
  options.backend = "tcp://127.0.0.1:*";
  auto broker = Broker::Start(options);
  EXPECT_TRUE(broker.ok()) << broker.status().ToString();
  return broker.ok() ? std::move(broker).value() : nullptr;
}

zmq::socket_t Socket(zmq::context_t& context, zmq::socket_type type, const std::string& endpoint) {
  zmq::socket_t socket(context, type);
  socket.set(zmq::sockopt::linger, 0);
  socket.set(zmq::sockopt::rcvtimeo, 10000);
  socket.connect(endpoint);
  return socket;
}

std::string Receive(zmq::socket_t& socket) {
  zmq::message_t message;
  if (!socket.recv(message, zmq::recv_flags::none)) return "(nothing)";
  return message.to_string();
}

// The bound endpoints are real ports; a client's request reaches a worker on the backend
// and the worker's reply reaches the client, unchanged.
TEST(BrokerTest, ForwardsARequestAndItsReply) {
  const auto broker = StartLocalBroker();
  ASSERT_NE(broker, nullptr);
  EXPECT_EQ(broker->frontend().find("tcp://127.0.0.1:"), 0u);
  EXPECT_EQ(broker->frontend().find('*'), std::string::npos);
  EXPECT_NE(broker->frontend(), broker->backend());
  zmq::context_t context;
  zmq::socket_t worker = Socket(context, zmq::socket_type::rep, broker->backend());
  zmq::socket_t client = Socket(context, zmq::socket_type::req, broker->frontend());
  client.send(zmq::str_buffer("where am I?"), zmq::send_flags::none);
  EXPECT_EQ(Receive(worker), "where am I?");
  worker.send(zmq::str_buffer("location 7"), zmq::send_flags::none);
  EXPECT_EQ(Receive(client), "location 7");
  broker->Stop();
  broker->Stop();  // idempotent
}

// Two workers share the requests: one client's requests in turn reach both, each reply
// going back to the client. (A worker is sent requests once its connection is up, so the
// client keeps asking until both have served some, at most 100 times.)
TEST(BrokerTest, WorkersShareTheRequests) {
  const auto broker = StartLocalBroker();
  ASSERT_NE(broker, nullptr);
  zmq::context_t context;
  zmq::socket_t workers[] = {Socket(context, zmq::socket_type::rep, broker->backend()),
                             Socket(context, zmq::socket_type::rep, broker->backend())};
  zmq::socket_t client = Socket(context, zmq::socket_type::req, broker->frontend());
  int served[2] = {0, 0};
  zmq::pollitem_t items[] = {{workers[0].handle(), 0, ZMQ_POLLIN, 0},
                             {workers[1].handle(), 0, ZMQ_POLLIN, 0}};
  for (int i = 0; i < 100 && (served[0] == 0 || served[1] == 0); ++i) {
    const std::string request = "request " + std::to_string(i);
    client.send(zmq::buffer(request), zmq::send_flags::none);
    ASSERT_EQ(zmq::poll(items, 2, std::chrono::seconds(10)), 1);
    const int w = (items[0].revents & ZMQ_POLLIN) != 0 ? 0 : 1;
    EXPECT_EQ(Receive(workers[w]), request);
    workers[w].send(zmq::buffer("served by " + std::to_string(w)), zmq::send_flags::none);
    EXPECT_EQ(Receive(client), "served by " + std::to_string(w));
    ++served[w];
  }
  EXPECT_GT(served[0], 0);
  EXPECT_GT(served[1], 0);
}

// Missing or equal endpoints and a tiny message limit are InvalidArgument; an endpoint
// that cannot be bound is IoError naming it.
TEST(BrokerTest, RefusesBadOptionsAndEndpoints) {
  BrokerOptions options;
  options.frontend = "";
  EXPECT_EQ(options.Validate().code(), StatusCode::kInvalidArgument);
  options = BrokerOptions();
  options.backend = options.frontend;
  EXPECT_EQ(options.Validate().code(), StatusCode::kInvalidArgument);
  options = BrokerOptions();
  options.max_message_bytes = 100;
  EXPECT_EQ(Broker::Start(options).status().code(), StatusCode::kInvalidArgument);
  options = BrokerOptions();
  options.frontend = "tcp://no-such-interface-name:1";
  options.backend = "tcp://127.0.0.1:*";
  const auto broker = Broker::Start(options);
  EXPECT_EQ(broker.status().code(), StatusCode::kIoError);
  EXPECT_NE(broker.status().message().find("no-such-interface-name"), std::string::npos)
      << broker.status().message();
}

}  // namespace
}  // namespace sceneloc
