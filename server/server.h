// sceneloc-server's network side: a ZeroMQ ROUTER socket, an I/O thread that owns it, and
// a fixed pool of workers behind a bounded queue.
//
//   client ──▶ ROUTER (I/O thread) ── parse, check size and frames ──┬─ stats, list_maps:
//                 ▲                                                 │  answered inline
//                 │                                                 ├─ queue full: OVERLOADED
//                 │                                                 ▼
//                 └──── inproc PULL ◀── PUSH (one per worker) ◀── workers: RequestHandler
//
// ReloadMap requests go to the map loader thread instead (server/map_loader.h), which also
// follows the maps directory and SIGHUP: a slow load never holds a worker; its reply
// takes the workers' path (a PUSH of its own into the same PULL).
//
// ZeroMQ sockets are not thread-safe, so each has one owner thread: the I/O thread owns the
// ROUTER and the PULL, each worker and the loader its own PUSH. Every request gets exactly one
// reply (an answer, an error, OVERLOADED or UNAVAILABLE), except one larger than ZMQ_MAXMSGSIZE
// (twice limits.max_message_bytes), whose sender ZeroMQ disconnects.
//
// Framing: a request is [identity][empty][Request] (what REQ sends, and what a DEALER
// must send) or [identity][Request]; the reply mirrors it.
//
// Thread-safe: endpoint() and Shutdown() may be called from any thread.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include "common/util/status.h"
#include "common/util/thread_pool.h"
#include "server/map_registry.h"
#include "server/server_options.h"

namespace sceneloc {

class Server {
 public:
  virtual ~Server() = default;  // Shutdown()s first

  // Binds options.endpoint and starts serving the maps of `registry` (which must outlive
  // the server; it may be changed while serving), and the map loader (watching
  // options.maps_dir when options.watch_maps). One request's scoring spreads over
  // `engine_pool` (which must outlive the server) while its threads are idle; null: the
  // server makes its own of options.threads threads. Errors: invalid options (InvalidArgument),
  // an endpoint that cannot be bound or a maps directory that cannot be watched (IoError,
  // naming it).
  static StatusOr<std::unique_ptr<Server>> Start(const ServerOptions& options,
                                                 MapRegistry* registry,
                                                 ThreadPool* engine_pool = nullptr);

  // The endpoint actually bound (ZMQ_LAST_ENDPOINT): tcp://127.0.0.1:* becomes the port
  // the system chose. In worker mode (options.connect), the broker backend connected to.
  virtual std::string endpoint() const = 0;

  // The operator endpoint's HOST:PORT actually listened on (options.metrics_endpoint, with
  // port 0 become the chosen port; server/health.h); empty when not set.
  virtual std::string metrics_endpoint() const = 0;

  // Queues a reload of every map file in options.maps_dir on the loader thread, and the
  // unloading of maps whose file is gone (what SIGHUP does). Returns at once.
  virtual void ReloadAll() = 0;

  // Waits until the loader has acted on everything queued and every change of the maps
  // directory seen before the call (tests use it). False at the timeout.
  virtual bool WaitForLoader(std::chrono::milliseconds timeout) = 0;

  // Stops taking new work (requests arriving now get UNAVAILABLE), waits up to
  // options.drain_timeout_s for the requests in flight to be answered (those still
  // queued at the deadline get UNAVAILABLE), then closes the socket and joins every
  // thread. Idempotent.
  virtual void Shutdown() = 0;
};

}  // namespace sceneloc
