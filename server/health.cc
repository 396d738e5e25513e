#include "server/health.h"

#include <utility>

#include "server/metrics.h"

namespace sceneloc {
namespace {

HttpResponse Text(int status, std::string body) {
  return {status, "text/plain; charset=utf-8", std::move(body) + "\n"};
}

}  // namespace

HttpResponse Liveness(const ServerHealth& health) {
  if (health.io_silence > kMaxIoSilence) {
    return Text(503, "not alive: the I/O thread has not woken for " +
                         std::to_string(static_cast<int>(health.io_silence.count())) + " s");
  }
  return Text(200, "alive");
}

HttpResponse Readiness(const ServerHealth& health) {
  HttpResponse live = Liveness(health);
  if (live.status != 200) return live;
  if (health.draining) return Text(503, "not ready: shutting down");
  if (health.maps_loaded == 0) return Text(503, "not ready: no map loaded");
  if (health.worker_mode && !health.broker_connected) {
    return Text(503, "not ready: not connected to the broker at " + health.broker);
  }
  return Text(200, "ready: " + std::to_string(health.maps_loaded) + " map(s) loaded");
}

StatusOr<std::unique_ptr<HttpEndpoint>> StartOperatorEndpoint(
    const std::string& address, std::function<std::string()> metrics,
    std::function<ServerHealth()> health) {
  std::map<std::string, HttpEndpoint::Handler> handlers;
  handlers["/metrics"] = [metrics = std::move(metrics)] {
    return HttpResponse{200, Metrics::kContentType, metrics()};
  };
  handlers["/healthz"] = [health] { return Liveness(health()); };
  handlers["/readyz"] = [health] { return Readiness(health()); };
  return HttpEndpoint::Start(address, std::move(handlers));
}

}  // namespace sceneloc
