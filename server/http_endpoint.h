// A small HTTP endpoint for operators: GET handlers on a few paths (the server's
// /metrics, /healthz and /readyz), served by civetweb on its own threads.
//
// It answers GET only (405 otherwise), 404 for a path it does not know, and never serves
// files. Each handler runs on a civetweb thread while the server keeps serving ZeroMQ, so
// handlers must be thread-safe; a handler that throws gets a 500 with the message.
//
// Thread-safe: address() may be called from any thread; Stop() (or the destructor) waits
// for the handlers running and returns once none will run again.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>

#include "common/util/status.h"

namespace sceneloc {

struct HttpResponse {
  int status = 200;
  std::string content_type = "text/plain; charset=utf-8";
  std::string body;
};

class HttpEndpoint {
 public:
  using Handler = std::function<HttpResponse()>;

  virtual ~HttpEndpoint() = default;

  // Listens on `address`, HOST:PORT (e.g. 127.0.0.1:9464; port 0 = one the system
  // chooses; HOST 0.0.0.0 = every interface), serving `handlers` by exact path ("/metrics").
  // Errors: a malformed address (InvalidArgument); an address that cannot be listened on,
  // e.g. a port already taken (IoError naming it and civetweb's reason).
  static StatusOr<std::unique_ptr<HttpEndpoint>> Start(const std::string& address,
                                                       std::map<std::string, Handler> handlers);

  // HOST:PORT actually listened on (port 0 becomes the chosen port).
  virtual std::string address() const = 0;

  // Stops listening and waits for the handlers running. Idempotent.
  virtual void Stop() = 0;
};

// Checks an HTTP endpoint address, HOST:PORT with a numeric port in 0..65535.
Status ValidateHttpAddress(const std::string& address);

}  // namespace sceneloc
