// The server's operator endpoint (server.metrics_endpoint): Prometheus metrics and the
// HTTP liveness and readiness probes an orchestrator (Kubernetes, compose) asks.
//
//   GET /metrics  the Prometheus text format (server/metrics.h)
//   GET /healthz  liveness: 200 while the I/O thread turns (it wakes at least once a
//                 second); 503 when it has not for kMaxIoSilence — restart the process
//   GET /readyz   readiness: 200 when live, not shutting down, at least one map loaded and,
//                 in worker mode, connected to the broker; else 503 saying which is missing
//                 — send no traffic yet (or any more)
//
// Each body is one line of plain text saying why, so `curl` answers an operator too.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <string>

#include "common/util/status.h"
#include "server/http_endpoint.h"

namespace sceneloc {

// What the probes judge (filled by the server when asked).
struct ServerHealth {
  std::chrono::duration<double> io_silence{0};  // since the I/O thread last woke
  bool draining = false;                        // shutting down
  size_t maps_loaded = 0;
  bool worker_mode = false;       // connected out to a broker (server.connect)
  bool broker_connected = false;  // worker mode: its connection to the broker is up
  std::string broker;             // worker mode: the broker's address
};

// The I/O thread silent this long is not alive: a second's wake-up missed 10 times.
constexpr std::chrono::seconds kMaxIoSilence{10};

HttpResponse Liveness(const ServerHealth& health);
HttpResponse Readiness(const ServerHealth& health);

// Serves /metrics (the text `metrics` returns), /healthz and /readyz (judging what
// `health` returns) on `address` (HttpEndpoint::Start, whose errors it returns).
StatusOr<std::unique_ptr<HttpEndpoint>> StartOperatorEndpoint(const std::string& address,
                                                              std::function<std::string()> metrics,
                                                              std::function<ServerHealth()> health);

}  // namespace sceneloc
