// sceneloc-broker's core: many sceneloc-server workers behind one address.
//
// A ROUTER socket bound at the frontend takes clients' requests; a DEALER socket bound at
// the backend hands them to the workers that connect to it (sceneloc-server --connect),
// round robin, and passes their replies back. The forwarding is libzmq's own
// zmq_proxy_steerable: the broker never parses a message or keeps any routing of its own,
// so clients and the wire protocol do not change, workers come and go while clients run,
// and a worker lost mid-request costs only that request's client a retry (sceneloc::Client
// retries on a fresh socket after its timeout).
//
// Every worker behind one broker must serve the same maps (the proxy does not look inside
// requests): a fleet with more maps than one machine holds is laid out as groups, one
// broker per group (README "A fleet").
//
// Thread-safe: Stop() may be called from any thread, once the broker has started.
#pragma once

#include <memory>
#include <string>

#include "common/util/status.h"

namespace sceneloc {

struct BrokerOptions {
  std::string frontend = "tcp://*:5555";  // where clients connect
  std::string backend = "tcp://*:5556";   // where workers connect (sceneloc-server --connect)
  // Largest message read from a client, bytes; a larger one disconnects it (ZMQ_MAXMSGSIZE).
  // Twice the servers' default limits.max_message_bytes, as the servers themselves set it.
  int64_t max_message_bytes = int64_t{16} << 20;

  Status Validate() const;
};

class Broker {
 public:
  virtual ~Broker() = default;
  // Binds both endpoints and starts forwarding on its own thread. Errors: invalid options
  // (InvalidArgument), an endpoint that cannot be bound (IoError naming it).
  static StatusOr<std::unique_ptr<Broker>> Start(const BrokerOptions& options);
  // The endpoints actually bound (tcp://127.0.0.1:* becomes the port the system chose).
  virtual std::string frontend() const = 0;
  virtual std::string backend() const = 0;
  // Stops forwarding and closes both sockets; messages in flight are dropped (their
  // clients retry). Also done by the destructor.
  virtual void Stop() = 0;
};

}  // namespace sceneloc
