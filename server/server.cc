// Start-up: the ZmqServer's sockets and threads (zmq_server.h lists the files of its other
// parts), and Server::Start.
#include "server/server.h"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "server/zmq_server.h"

namespace sceneloc {
namespace {

// Worker mode: the frontend's connection events (zmq_socket_monitor), for readiness.
constexpr char kMonitorEndpoint[] = "inproc://sceneloc-monitor";
// How long closing the ROUTER may keep trying to deliver the last replies.
constexpr int kLingerMs = 1000;

}  // namespace

ZmqServer::ZmqServer(const ServerOptions& options, MapRegistry* registry, ThreadPool* engine_pool,
                     std::unique_ptr<FrameKeeper> keeper)
    : options_(options),
      registry_(registry),
      own_engine_pool_(engine_pool != nullptr ? nullptr
                                              : std::make_unique<ThreadPool>(options.threads)),
      engine_pool_(engine_pool != nullptr ? engine_pool : own_engine_pool_.get()),
      handler_(options, registry, engine_pool_, &stats_, std::move(keeper)),
      // Requests parsed on a worker (larger than kInlineParseBytes) hold all workers but
      // one at most: small requests always have a worker (with one worker, no lane).
      queue_(static_cast<size_t>(options.queue_capacity), std::max(1, options.threads - 1)),
      // Worker mode: a DEALER connected to the broker's DEALER backend receives what the
      // broker's ROUTER frontend read, [client identity][empty][request], exactly what
      // our own ROUTER would; replies go back the same way. Nothing else changes.
      frontend_(context_,
                options.connect.empty() ? zmq::socket_type::router : zmq::socket_type::dealer),
      replies_(context_, zmq::socket_type::pull),
      control_(context_, zmq::socket_type::pull),
      loader_push_(context_, zmq::socket_type::push),
      monitor_(context_, zmq::socket_type::pair) {}

Status ZmqServer::Bind() {
  if (options_.auth.enabled) {
    // The ZAP handler is bound before the socket, so no connection is admitted unchecked.
    auto zap = ZapHandler::Start(context_, options_.auth);
    if (!zap.ok()) return zap.status();
    zap_ = std::move(zap).value();
  }
  try {
    if (zap_ != nullptr) zap_->Secure(&frontend_);
    frontend_.set(zmq::sockopt::maxmsgsize, 2 * options_.limits.max_message_bytes);
    frontend_.set(zmq::sockopt::linger, kLingerMs);
    if (options_.connect.empty()) {
      frontend_.set(zmq::sockopt::router_mandatory, true);
      frontend_.bind(options_.endpoint);
      endpoint_ = frontend_.get(zmq::sockopt::last_endpoint);
    } else {
      // Connection events are watched before connecting, so the first one is seen.
      if (zmq_socket_monitor(frontend_.handle(), kMonitorEndpoint,
                             ZMQ_EVENT_CONNECTED | ZMQ_EVENT_DISCONNECTED) != 0) {
        throw zmq::error_t();
      }
      monitor_.connect(kMonitorEndpoint);
      frontend_.connect(options_.connect);
      endpoint_ = options_.connect;
    }
    replies_.bind(kRepliesEndpoint);
    control_.bind(kControlEndpoint);
    loader_push_.set(zmq::sockopt::linger, -1);
    loader_push_.connect(kRepliesEndpoint);
  } catch (const zmq::error_t& e) {
    return IoError(options_.connect.empty()
                       ? "cannot bind '" + options_.endpoint + "': " + e.what()
                       : "cannot connect to '" + options_.connect + "': " + e.what());
  }
  return Status::Ok();
}

Status ZmqServer::StartThreads() {
  MapLoader::Options loader_options;
  loader_options.maps_dir = options_.maps_dir;
  loader_options.watch = options_.watch_maps;
  loader_options.debounce = std::chrono::milliseconds(options_.reload_debounce_ms);
  loader_options.max_waiting_reloads = kMaxWaitingReloads;
  auto loader = MapLoader::Start(loader_options, registry_);
  if (!loader.ok()) return loader.status();
  loader_ = std::move(loader).value();
  for (int i = 0; i < options_.threads; ++i) workers_.emplace_back([this] { WorkerLoop(); });
  // The sockets move to the I/O thread here; thread creation orders the accesses.
  MutexLock lock(&shutdown_mutex_);
  io_thread_ = std::thread([this] { IoLoop(); });
  return Status::Ok();
}

Status ZmqServer::StartOperatorHttp() {
  if (options_.metrics_endpoint.empty()) return Status::Ok();
  auto http = StartOperatorEndpoint(
      options_.metrics_endpoint, [this] { return metrics_.Render(Gauges(), *registry_); },
      [this] { return Health(); });
  if (!http.ok()) return http.status();
  http_ = std::move(http).value();
  spdlog::info("metrics and health on http://{}/metrics, /healthz, /readyz", http_->address());
  return Status::Ok();
}

std::string ZmqServer::metrics_endpoint() const {
  return http_ != nullptr ? http_->address() : std::string();
}

void ZmqServer::ReloadAll() {
  if (zap_ != nullptr) (void)zap_->ReloadClients();  // logs its own failure
  loader_->ReloadAll();
}

bool ZmqServer::WaitForLoader(std::chrono::milliseconds timeout) {
  return loader_->WaitIdle(timeout);
}

StatusOr<std::unique_ptr<Server>> Server::Start(const ServerOptions& options, MapRegistry* registry,
                                                ThreadPool* engine_pool) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  std::unique_ptr<FrameKeeper> keeper;
  if (!options.keep_frames.dir.empty()) {
    auto opened = FrameKeeper::Open(options.keep_frames);
    if (!opened.ok()) return opened.status();
    keeper = std::move(opened).value();
  }
  auto server = std::make_unique<ZmqServer>(options, registry, engine_pool, std::move(keeper));
  SCENELOC_RETURN_IF_ERROR(server->Bind());
  // The operator endpoint first: a taken port stops the start before anything serves.
  SCENELOC_RETURN_IF_ERROR(server->StartOperatorHttp());
  SCENELOC_RETURN_IF_ERROR(server->StartThreads());
  spdlog::info("serving {} map(s) {} {} with {} worker(s), queue capacity {}{}",
               registry->List().size(), options.connect.empty() ? "on" : "as a worker of broker",
               server->endpoint(), options.threads, options.queue_capacity,
               options.watch_maps ? ", watching " + options.maps_dir : std::string());
  return std::unique_ptr<Server>(std::move(server));
}

}  // namespace sceneloc
