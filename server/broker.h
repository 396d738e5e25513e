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
// broker per group (docs/operations.md "A fleet").
//
// With auth, the broker is where robots authenticate: CURVE on the frontend and the same
// ZAP check a server makes (zap_handler.h) against the same authorised-clients file, so a
// key not in it never completes the handshake. The backend stays plain: the workers are
// the broker's own, on a network that only they reach (bind it on a private interface).
// A key removed from the file (ReloadClients, SIGHUP) cannot connect again, but the proxy
// does not look at requests, so connections it admitted before keep working until they
// close; restart the broker to cut them at once.
//
// Thread-safe: Stop() may be called from any thread, once the broker has started.
#pragma once

#include <memory>
#include <string>

#include "common/util/status.h"
#include "server/server_options.h"

namespace sceneloc {

struct BrokerOptions {
  std::string frontend = "tcp://*:5555";  // where clients connect
  std::string backend = "tcp://*:5556";   // where workers connect (sceneloc-server --connect)
  // Largest message read from a client, bytes; a larger one disconnects it (ZMQ_MAXMSGSIZE).
  // Twice the servers' default limits.max_message_bytes, as the servers themselves set it.
  int64_t max_message_bytes = int64_t{16} << 20;
  // CURVE and the authorised-clients check on the frontend: the auth: section of a server's
  // settings (its enabled, server_key and clients mean the same here).
  AuthOptions auth;

  Status Validate() const;
};

class Broker {
 public:
  virtual ~Broker() = default;
  // Binds both endpoints and starts forwarding on its own thread. Errors: invalid options
  // (InvalidArgument), an endpoint that cannot be bound (IoError naming it), an unreadable
  // server key or clients file (the error names it).
  static StatusOr<std::unique_ptr<Broker>> Start(const BrokerOptions& options);
  // The endpoints actually bound (tcp://127.0.0.1:* becomes the port the system chose).
  virtual std::string frontend() const = 0;
  virtual std::string backend() const = 0;
  // Re-reads auth.clients for the connections made from now on; on an error the old list
  // stays in force. FailedPrecondition without auth.
  virtual Status ReloadClients() = 0;
  // Stops forwarding and closes both sockets; messages in flight are dropped (their
  // clients retry). Also done by the destructor.
  virtual void Stop() = 0;
};

}  // namespace sceneloc
