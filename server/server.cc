#include "server/server.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <optional>
#include <thread>
#include <vector>
#include <zmq.hpp>

#include "common/util/mutex.h"
#include "common/util/thread_annotations.h"
#include "common/util/thread_pool.h"
#include "proto/sceneloc.pb.h"
#include "proto/wire.h"
#include "server/bounded_queue.h"
#include "server/health.h"
#include "server/http_endpoint.h"
#include "server/map_loader.h"
#include "server/metrics.h"
#include "server/request_handler.h"
#include "server/server_stats.h"
#include "server/zap_handler.h"

namespace sceneloc {
namespace {

using Clock = std::chrono::steady_clock;

constexpr char kRepliesEndpoint[] = "inproc://sceneloc-replies";
constexpr char kControlEndpoint[] = "inproc://sceneloc-control";
// Worker mode: the frontend's connection events (zmq_socket_monitor), for readiness.
constexpr char kMonitorEndpoint[] = "inproc://sceneloc-monitor";
// The I/O thread wakes at least this often, so the liveness probe sees it turn.
constexpr std::chrono::milliseconds kMaxPollWait{1000};
// Worker mode: how often a missing broker is logged.
constexpr std::chrono::seconds kBrokerWarningInterval{10};
// reload_map requests waiting for the loader at once (reloads of one map coalesce into
// one load); more get OVERLOADED.
constexpr size_t kMaxWaitingReloads = 16;
// Identity + empty delimiter + request is the most a valid request has.
constexpr size_t kMaxFrames = 3;
// How long closing the ROUTER may keep trying to deliver the last replies.
constexpr int kLingerMs = 1000;

// Requests up to this size are parsed on the I/O thread (list_maps, stats, reload_map and
// most feature sets: microseconds); larger ones, which only a localise request may be, are
// parsed by the worker that takes them, so a burst of 8 MiB messages never holds up the
// I/O thread.
constexpr size_t kInlineParseBytes = 64 << 10;

// A request waiting for (or held by) a worker.
struct Job {
  zmq::message_t identity;
  bool delimited = false;  // the request had the empty delimiter frame; the reply gets one
  v1::Request request;     // valid when `parsed`
  bool parsed = true;
  zmq::message_t raw;  // the unparsed request when !parsed (the worker parses it)
  size_t bytes = 0;    // the request's size: counted in queued_bytes_ while queued or running
  Clock::time_point received;
  std::string client;  // the key name (ZAP User-Id) with auth on, else empty
};

// One request as read off the ROUTER.
struct Incoming {
  zmq::message_t identity;
  bool delimited = false;
  zmq::message_t payload;
  size_t frames = 0;
  size_t bytes = 0;
};

double MsSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

const char* KindName(const v1::Request& r) {
  switch (r.kind_case()) {
    case v1::Request::kLocalise:
      return "localise";
    case v1::Request::kListMaps:
      return "list_maps";
    case v1::Request::kReloadMap:
      return "reload_map";
    case v1::Request::kStats:
      return "stats";
    case v1::Request::KIND_NOT_SET:
      break;
  }
  return "unknown";
}

// The request id of a request that cannot be parsed (too large, malformed), when its
// first field is one: generated code writes fields in number order, so a client's id
// sits at the front. 0 otherwise.
uint64_t PeekRequestId(const zmq::message_t& payload) {
  const auto* p = static_cast<const uint8_t*>(payload.data());
  const size_t n = payload.size();
  if (n < 2 || p[0] != 0x08) return 0;  // field 1, varint
  uint64_t id = 0;
  for (size_t i = 1; i < n && i <= 10; ++i) {
    id |= static_cast<uint64_t>(p[i] & 0x7F) << (7 * (i - 1));
    if ((p[i] & 0x80) == 0) return id;
  }
  return 0;
}

// The reply's bytes, stamped with the protocol this server speaks.
zmq::message_t ReplyBody(v1::Reply reply) {
  reply.set_protocol(kProtocolVersion);
  zmq::message_t body(reply.ByteSizeLong());
  reply.SerializeToArray(body.data(), static_cast<int>(body.size()));
  return body;
}

// Sends [identity][empty?][reply] on `socket` (the ROUTER, or a worker's PUSH).
void SendReply(zmq::socket_t& socket, zmq::message_t& identity, bool delimited,
               const v1::Reply& reply) {
  socket.send(identity, zmq::send_flags::sndmore);
  if (delimited) socket.send(zmq::message_t(), zmq::send_flags::sndmore);
  zmq::message_t body = ReplyBody(reply);
  socket.send(body, zmq::send_flags::none);
}

v1::Reply ErrorReply(uint64_t request_id, v1::StatusCode code, const std::string& error) {
  v1::Reply reply;
  reply.set_request_id(request_id);
  reply.set_status(code);
  reply.set_error(error);
  return reply;
}

// UNIMPLEMENTED for a request of a newer protocol than this server speaks (nullopt when
// it speaks it); in worker mode marked retry_elsewhere, as a newer worker may be behind the
// same broker.
std::optional<v1::Reply> ProtocolRefusal(const v1::Request& request, bool worker_mode) {
  if (request.protocol() <= kProtocolVersion) return std::nullopt;
  v1::Reply reply =
      ErrorReply(request.request_id(), v1::UNIMPLEMENTED,
                 "the request speaks sceneloc protocol " + std::to_string(request.protocol()) +
                     "; this server speaks " + std::to_string(kProtocolVersion) +
                     " (upgrade the server, or use a client of its version)");
  reply.set_retry_elsewhere(worker_mode);
  return reply;
}

// Why a request is not admitted (empty: it is), and the server's estimate of when a retry
// would be, milliseconds.
struct Refusal {
  std::string why;
  double retry_after_ms = 0;
};

// An OVERLOADED reply: the refusal's reason and its retry hint, kept within [10 ms, 10 s].
v1::Reply OverloadedReply(uint64_t request_id, const Refusal& refusal) {
  v1::Reply reply = ErrorReply(request_id, v1::OVERLOADED,
                               "server is overloaded: " + refusal.why + "; retry later");
  reply.set_retry_after_ms(
      static_cast<uint32_t>(std::clamp(std::ceil(refusal.retry_after_ms), 10.0, 10000.0)));
  return reply;
}

void RecordAndLog(ServerStats* stats, const char* kind, const v1::Reply& reply,
                  Clock::time_point received) {
  const double ms = MsSince(received);
  const std::string& status = v1::StatusCode_Name(reply.status());
  stats->RecordReply(status, reply.kind_case() == v1::Reply::kLocalise, ms);
  if (reply.status() == v1::OK) {
    spdlog::debug("request {} {}: OK in {:.1f} ms", reply.request_id(), kind, ms);
  } else {
    spdlog::debug("request {} {}: {} in {:.1f} ms: {}", reply.request_id(), kind, status, ms,
                  reply.error());
  }
}

class ZmqServer final : public Server {
 public:
  ZmqServer(const ServerOptions& options, MapRegistry* registry, ThreadPool* engine_pool)
      : options_(options),
        registry_(registry),
        own_engine_pool_(engine_pool != nullptr ? nullptr
                                                : std::make_unique<ThreadPool>(options.threads)),
        engine_pool_(engine_pool != nullptr ? engine_pool : own_engine_pool_.get()),
        handler_(options, registry, engine_pool_, &stats_),
        queue_(static_cast<size_t>(options.queue_capacity)),
        // Worker mode: a DEALER connected to the broker's DEALER backend receives what the
        // broker's ROUTER frontend read, [client identity][empty][request], exactly what
        // our own ROUTER would; replies go back the same way. Nothing else changes.
        frontend_(context_,
                  options.connect.empty() ? zmq::socket_type::router : zmq::socket_type::dealer),
        replies_(context_, zmq::socket_type::pull),
        control_(context_, zmq::socket_type::pull),
        monitor_(context_, zmq::socket_type::pair),
        loader_push_(context_, zmq::socket_type::push) {}

  ~ZmqServer() override { Shutdown(); }

  Status Bind() {
    if (options_.auth.enabled) {
      // The ZAP handler is bound before the socket, so no connection is admitted unchecked.
      auto zap = ZapHandler::Start(context_, options_.auth);
      if (!zap.ok()) return zap.status();
      zap_ = std::move(zap).value();
    }
    try {
      if (zap_ != nullptr) {
        frontend_.set(zmq::sockopt::curve_server, true);
        frontend_.set(zmq::sockopt::curve_secretkey, zap_->server_key().secret_key);
        frontend_.set(zmq::sockopt::zap_domain, "sceneloc");
      }
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

  Status StartThreads() EXCLUDES(shutdown_mutex_) {
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

  // Serves options.metrics_endpoint (server/health.h), when set.
  Status StartOperatorHttp() {
    if (options_.metrics_endpoint.empty()) return Status::Ok();
    auto http = StartOperatorEndpoint(
        options_.metrics_endpoint, [this] { return metrics_.Render(Gauges(), *registry_); },
        [this] { return Health(); });
    if (!http.ok()) return http.status();
    http_ = std::move(http).value();
    spdlog::info("metrics and health on http://{}/metrics, /healthz, /readyz", http_->address());
    return Status::Ok();
  }

  std::string metrics_endpoint() const override {
    return http_ != nullptr ? http_->address() : std::string();
  }

  std::string endpoint() const override { return endpoint_; }

  void ReloadAll() override {
    if (zap_ != nullptr) (void)zap_->ReloadClients();  // logs its own failure
    loader_->ReloadAll();
  }

  bool WaitForLoader(std::chrono::milliseconds timeout) override {
    return loader_->WaitIdle(timeout);
  }

  void Shutdown() override EXCLUDES(shutdown_mutex_) {
    MutexLock lock(&shutdown_mutex_);
    if (!io_thread_.joinable()) return;
    draining_ = true;  // readiness fails from now on; liveness holds until the end
    try {
      zmq::socket_t stop(context_, zmq::socket_type::push);
      stop.set(zmq::sockopt::linger, -1);
      stop.connect(kControlEndpoint);
      stop.send(zmq::str_buffer("stop"), zmq::send_flags::none);
    } catch (const zmq::error_t& e) {
      spdlog::error("shutdown: cannot signal the I/O thread: {}", e.what());
    }
    io_thread_.join();
    if (http_ != nullptr) http_->Stop();
  }

 private:
  // --- I/O thread ---

  void IoLoop() {
    std::optional<Clock::time_point> drain_deadline;
    Clock::time_point next_summary = Clock::now() + SummaryInterval();
    for (;;) {
      if (drain_deadline && (outstanding_ == 0 || Clock::now() >= *drain_deadline)) break;
      std::vector<zmq::pollitem_t> items = {{frontend_.handle(), 0, ZMQ_POLLIN, 0},
                                            {replies_.handle(), 0, ZMQ_POLLIN, 0},
                                            {control_.handle(), 0, ZMQ_POLLIN, 0}};
      if (!options_.connect.empty()) items.push_back({monitor_.handle(), 0, ZMQ_POLLIN, 0});
      try {
        zmq::poll(items, PollTimeout(drain_deadline, next_summary));
        io_woke_.store(Clock::now().time_since_epoch().count(), std::memory_order_relaxed);
        if (items.size() > 3 && (items[3].revents & ZMQ_POLLIN)) ReadMonitorEvent();
        if (items[1].revents & ZMQ_POLLIN) ForwardReply();
        if (items[0].revents & ZMQ_POLLIN) ReadRequest(drain_deadline.has_value());
        if (items[2].revents & ZMQ_POLLIN) {
          zmq::message_t ignored;
          (void)control_.recv(ignored);
          drain_deadline =
              Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                 std::chrono::duration<double>(options_.drain_timeout_s));
          draining_ = true;
          spdlog::info("shutting down: draining {} request(s) in flight", outstanding_);
        }
      } catch (const zmq::error_t& e) {
        // Nothing a peer sends should get here; keep serving, but say so.
        spdlog::error("I/O thread: ZeroMQ error: {}", e.what());
        stats_.RecordReply("INTERNAL", false, 0);
      }
      WarnIfNoBroker();
      if (options_.summary_interval_s > 0 && Clock::now() >= next_summary) {
        LogSummary();
        next_summary = Clock::now() + SummaryInterval();
      }
    }
    FinishDrain();
  }

  Clock::duration SummaryInterval() const {
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
        options_.summary_interval_s > 0 ? options_.summary_interval_s : 3600.0));
  }

  std::chrono::milliseconds PollTimeout(const std::optional<Clock::time_point>& deadline,
                                        Clock::time_point next_summary) const {
    Clock::time_point wake = next_summary;
    if (deadline && *deadline < wake) wake = *deadline;
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(wake - Clock::now());
    return std::min(std::max(ms, std::chrono::milliseconds(0)) + std::chrono::milliseconds(1),
                    kMaxPollWait);
  }

  // Reads one multipart message, keeping at most kMaxFrames frames (the rest are read and
  // dropped so the socket stays in step).
  Incoming ReceiveFrames() {
    Incoming in;
    std::vector<zmq::message_t> frames;
    bool more = true;
    while (more) {
      zmq::message_t frame;
      if (!frontend_.recv(frame, zmq::recv_flags::dontwait)) break;
      more = frame.more();
      ++in.frames;
      in.bytes += frame.size();
      if (frames.size() < kMaxFrames) frames.push_back(std::move(frame));
    }
    if (!frames.empty()) in.identity = std::move(frames[0]);
    if (frames.size() == 3 && frames[1].size() == 0) {
      in.delimited = true;
      in.payload = std::move(frames[2]);
    } else if (frames.size() == 2) {
      in.payload = std::move(frames[1]);
    }
    return in;
  }

  void ReadRequest(bool draining) {
    const Clock::time_point received = Clock::now();
    Incoming in = ReceiveFrames();
    if (in.frames == 0) return;
    stats_.RecordRequest();
    const uint64_t peeked_id = PeekRequestId(in.payload);
    auto refuse = [&](v1::StatusCode code, const std::string& error) {
      const v1::Reply reply = ErrorReply(peeked_id, code, error);
      Record("request", nullptr, reply, received);
      ToClient(in.identity, in.delimited, reply);
    };
    if (in.frames > kMaxFrames || (in.frames == 3 && !in.delimited) || in.frames < 2) {
      return refuse(v1::INVALID_ARGUMENT, "a request is [empty frame][Request] (got " +
                                              std::to_string(in.frames - 1) +
                                              " frames after the identity)");
    }
    if (in.bytes > static_cast<size_t>(options_.limits.max_message_bytes)) {
      return refuse(v1::RESOURCE_EXHAUSTED,
                    "request is " + std::to_string(in.bytes) + " bytes; at most " +
                        std::to_string(options_.limits.max_message_bytes) + " are accepted");
    }
    auto job = std::make_unique<Job>();
    job->bytes = in.bytes;
    job->parsed = in.payload.size() <= kInlineParseBytes;
    if (job->parsed &&
        !job->request.ParseFromArray(in.payload.data(), static_cast<int>(in.payload.size()))) {
      return refuse(v1::INVALID_ARGUMENT, "request is not a valid sceneloc.v1.Request");
    }
    if (job->parsed) {
      if (const auto refusal = ProtocolRefusal(job->request, !options_.connect.empty())) {
        Record(KindName(job->request), &job->request, *refusal, received);
        return ToClient(in.identity, in.delimited, *refusal);
      }
    }
    if (zap_ != nullptr) {
      job->client = UserOf(in.payload);
      const Status allowed = CheckPermission(job->client, job->parsed ? &job->request : nullptr);
      if (!allowed.ok()) return refuse(v1::PERMISSION_DENIED, allowed.message());
    }
    if (draining) return refuse(v1::UNAVAILABLE, "server is shutting down");
    if (!job->parsed) job->raw = std::move(in.payload);
    job->identity = std::move(in.identity);
    job->delimited = in.delimited;
    job->received = received;
    Dispatch(std::move(job));
  }

  // The name of the key a message came with (set by the ZAP handler); empty without one.
  static std::string UserOf(zmq::message_t& payload) {
    try {
      return payload.gets("User-Id");
    } catch (const zmq::error_t&) {
      return {};
    }
  }

  // With auth on: the request's key (its name, set by the ZAP handler) must still be in the
  // clients file, and reload_map needs one marked admin. `request` is null when the
  // request is too large to be parsed here (then it can only be a localise request).
  Status CheckPermission(const std::string& user, const v1::Request* request) const {
    const ZapHandler::Role role = zap_->RoleOf(user);
    if (role == ZapHandler::Role::kUnknown) {
      return PermissionDenied("key '" + user + "' is no longer in " + options_.auth.clients);
    }
    if (request != nullptr && request->kind_case() == v1::Request::kReloadMap &&
        role != ZapHandler::Role::kAdmin) {
      return PermissionDenied("reload_map needs an admin key; '" + user +
                              "' is not marked admin in " + options_.auth.clients);
    }
    return Status::Ok();
  }

  void Dispatch(std::unique_ptr<Job> job) {
    if (job->parsed && job->request.kind_case() == v1::Request::kReloadMap) {
      return DispatchReload(std::move(job));
    }
    if (job->parsed && RequestHandler::IsCheap(job->request)) {
      v1::Reply reply;
      handler_.Handle(job->request, job->received, &reply);
      Record(KindName(job->request), &job->request, reply, job->received);
      ToClient(job->identity, job->delimited, reply);
      return;
    }
    const std::string connection = ConnectionKey(job->identity);
    const size_t bytes = job->bytes;
    Refusal refusal = AdmissionRefusal(connection, job->client, bytes);
    if (refusal.why.empty()) refusal = WaitRefusal();
    if (refusal.why.empty()) {
      const std::string client = job->client;
      if (queue_.TryPush(job)) {
        ++outstanding_;
        Track(connection, client);
        queued_bytes_ += static_cast<int64_t>(bytes);
        return;
      }
      refusal = {std::to_string(options_.queue_capacity) +
                     " requests are already waiting (server.queue_capacity)",
                 QueuedWorkMs()};
    }
    const uint64_t id = job->parsed ? job->request.request_id() : PeekRequestId(job->raw);
    const v1::Reply reply = OverloadedReply(id, refusal);
    Record(job->parsed ? KindName(job->request) : "localise", job->parsed ? &job->request : nullptr,
           reply, job->received);
    ToClient(job->identity, job->delimited, reply);
  }

  // The recent mean time a request holds a worker, ms; 100 before the first one.
  double ServiceMs() const {
    const double ms = service_ms_.load(std::memory_order_relaxed);
    return ms > 0 ? ms : 100.0;
  }

  // The work waiting for a worker, estimated in ms of the pool's time.
  double QueuedWorkMs() const {
    return static_cast<double>(queue_.size()) * service_ms_.load(std::memory_order_relaxed) /
           options_.threads;
  }

  // Admits when the work queued ahead of a new request is estimated to take no longer than
  // limits.max_queue_wait_ms; else the estimate and the limit, and as the retry hint the
  // time for the queue to drain below the limit.
  Refusal WaitRefusal() const {
    // The requests waiting ahead of this one; those already running are not counted (an
    // idle server admits anything, however slow).
    const double wait_ms = QueuedWorkMs();
    const int limit = options_.limits.max_queue_wait_ms;
    if (wait_ms <= limit) return {};
    return {"about " + std::to_string(static_cast<int>(wait_ms)) + " ms of work (" +
                std::to_string(queue_.size()) + " requests of ~" +
                std::to_string(static_cast<int>(ServiceMs())) +
                " ms) is queued ahead of this request; limits.max_queue_wait_ms is " +
                std::to_string(limit),
            wait_ms - limit + ServiceMs() / options_.threads};
  }

  static std::string ConnectionKey(const zmq::message_t& identity) {
    return std::string(identity.data<char>(), identity.size());
  }

  // Admits a request of `bytes` from `connection` (with auth on, made with the key named
  // `client`) unless it would pass a per-connection, per-key or byte limit; else which,
  // with the figures. Each limit is freed by a running request finishing: the retry hint.
  Refusal AdmissionRefusal(const std::string& connection, const std::string& client,
                           size_t bytes) const {
    const auto it = in_flight_.find(connection);
    const int mine = it == in_flight_.end() ? 0 : it->second.count;
    if (mine >= options_.limits.max_in_flight_per_client) {
      return {"this connection already has " + std::to_string(mine) +
                  " requests queued or running, the most one connection may have "
                  "(limits.max_in_flight_per_client)",
              ServiceMs()};
    }
    if (!client.empty()) {
      const auto k = key_in_flight_.find(client);
      const int keyed = k == key_in_flight_.end() ? 0 : k->second;
      if (keyed >= options_.limits.max_in_flight_per_key) {
        return {"the connections of key '" + client + "' already have " + std::to_string(keyed) +
                    " requests queued or running, the most one key may have "
                    "(limits.max_in_flight_per_key)",
                ServiceMs()};
      }
    }
    const int64_t held = queued_bytes_;
    if (held + static_cast<int64_t>(bytes) > options_.limits.max_queued_bytes) {
      return {"requests queued or running hold " + std::to_string(held) + " bytes; this one (" +
                  std::to_string(bytes) + " bytes) would pass limits.max_queued_bytes (" +
                  std::to_string(options_.limits.max_queued_bytes) + ")",
              ServiceMs()};
    }
    return {};
  }

  // Counts an admitted request against its connection and key until Released().
  void Track(const std::string& connection, const std::string& client) {
    InFlight& entry = in_flight_[connection];
    ++entry.count;
    entry.client = client;
    if (!client.empty()) ++key_in_flight_[client];
  }

  // Hands a ReloadMap request to the loader thread, which answers it through loader_push_.
  void DispatchReload(std::unique_ptr<Job> job) {
    const uint64_t id = job->request.request_id();
    auto refuse = [&](v1::StatusCode code, const std::string& error) {
      const v1::Reply reply = ErrorReply(id, code, error);
      Record("reload_map", &job->request, reply, job->received);
      ToClient(job->identity, job->delimited, reply);
    };
    const Status checked = RequestHandler::CheckReload(job->request.reload_map());
    if (!checked.ok()) return refuse(ToWireCode(checked.code()), checked.message());
    const std::string map = job->request.reload_map().map();
    std::shared_ptr<Job> shared = std::move(job);
    const MapLoader::Queued queued =
        loader_->Reload(map, [this, shared](const MapLoader::LoadResult* loaded) {
          // On the loader thread: the only user of loader_push_.
          v1::Reply reply;
          if (loaded != nullptr) {
            RequestHandler::FillReloadReply(shared->request.request_id(), *loaded, &reply);
          } else {
            reply = ErrorReply(shared->request.request_id(), v1::UNAVAILABLE,
                               "server shut down before the reload was started");
          }
          Record("reload_map", &shared->request, reply, shared->received);
          try {
            SendReply(loader_push_, shared->identity, shared->delimited, reply);
          } catch (const zmq::error_t& e) {
            spdlog::error("map loader: cannot pass a reply to the I/O thread: {}", e.what());
          }
        });
    if (queued == MapLoader::Queued::kQueued) {
      ++outstanding_;
      Track(ConnectionKey(shared->identity), shared->client);
      return;
    }
    job = std::make_unique<Job>(std::move(*shared));
    if (queued == MapLoader::Queued::kOverloaded) {
      // A map load takes about a second (a 22 MB map: 0.3-1 s); the hint is one load.
      const v1::Reply reply = OverloadedReply(
          id,
          {std::to_string(kMaxWaitingReloads) + " reload_map requests are already waiting", 1000});
      Record("reload_map", &job->request, reply, job->received);
      return ToClient(job->identity, job->delimited, reply);
    }
    refuse(v1::UNAVAILABLE, "server is shutting down");
  }

  // Moves one finished reply from a worker or the loader to its client.
  void ForwardReply() {
    std::vector<zmq::message_t> frames;
    bool more = true;
    while (more) {
      zmq::message_t frame;
      if (!replies_.recv(frame, zmq::recv_flags::dontwait)) return;
      more = frame.more();
      frames.push_back(std::move(frame));
    }
    Released(ConnectionKey(frames.front()));  // the identity frame
    Deliver(frames);
    --outstanding_;
  }

  // Sends [identity][empty?][reply] to a client (I/O thread).
  void ToClient(zmq::message_t& identity, bool delimited, const v1::Reply& reply) {
    std::vector<zmq::message_t> frames;
    frames.push_back(std::move(identity));
    if (delimited) frames.emplace_back();
    frames.push_back(ReplyBody(reply));
    Deliver(frames);
  }

  // Sends one reply's frames on the ROUTER without ever blocking the I/O thread. The ROUTER
  // is ZMQ_ROUTER_MANDATORY, so a reply that cannot be delivered is known rather than
  // silently dropped: the client has gone (EHOSTUNREACH), or it has stopped reading and
  // its connection holds ZeroMQ's high-water mark of unread replies (EAGAIN). Such a reply
  // is dropped, counted (stats: replies_undelivered) and logged at most once a second.
  void Deliver(std::vector<zmq::message_t>& frames) {
    const char* why = nullptr;
    try {
      for (size_t i = 0; i < frames.size(); ++i) {
        const bool last = i + 1 == frames.size();
        const auto flags =
            zmq::send_flags::dontwait | (last ? zmq::send_flags::none : zmq::send_flags::sndmore);
        if (!frontend_.send(frames[i], flags)) {
          why = "its connection has the most unread replies ZeroMQ holds (it stopped reading)";
          break;
        }
      }
    } catch (const zmq::error_t& e) {
      if (e.num() != EHOSTUNREACH) throw;
      why = "the client has gone";
    }
    if (why == nullptr) return;
    stats_.RecordUndelivered();
    metrics_.RecordUndelivered();
    ++undelivered_since_log_;
    const Clock::time_point now = Clock::now();
    if (now - last_undelivered_log_ >= std::chrono::seconds(1)) {
      spdlog::warn("a reply was not delivered: {} ({} undelivered since the last such line)", why,
                   undelivered_since_log_);
      last_undelivered_log_ = now;
      undelivered_since_log_ = 0;
    }
  }

  void Released(const std::string& connection) {
    const auto it = in_flight_.find(connection);
    if (it == in_flight_.end()) return;
    if (!it->second.client.empty()) {
      const auto k = key_in_flight_.find(it->second.client);
      if (k != key_in_flight_.end() && --k->second <= 0) key_in_flight_.erase(k);
    }
    if (--it->second.count <= 0) in_flight_.erase(it);
  }

  void FinishDrain() {
    for (std::unique_ptr<Job>& job : queue_.Close()) {
      const v1::Reply reply = ErrorReply(job->request.request_id(), v1::UNAVAILABLE,
                                         "server shut down before this request was started");
      Record(KindName(job->request), &job->request, reply, job->received);
      ToClient(job->identity, job->delimited, reply);
      --outstanding_;
    }
    for (std::thread& worker : workers_) worker.join();
    loader_->Stop();  // finishes its load; queued reloads are answered UNAVAILABLE
    try {
      while (outstanding_ > 0 && replies_.handle() != nullptr) {
        zmq::pollitem_t item{replies_.handle(), 0, ZMQ_POLLIN, 0};
        if (zmq::poll(&item, 1, std::chrono::milliseconds(0)) == 0) break;
        ForwardReply();
      }
    } catch (const zmq::error_t& e) {
      spdlog::error("shutdown: {}", e.what());
    }
    LogSummary();
    frontend_.close();
    replies_.close();
    control_.close();
    monitor_.close();
    loader_push_.close();  // the loader thread has ended
    io_thread_done_ = true;
  }

  void LogSummary() const {
    const StatsSnapshot s = stats_.Snapshot();
    std::string statuses, maps;
    for (const auto& [status, count] : s.replies_by_status) {
      statuses += fmt::format(" {}={}", status, count);
    }
    for (const auto& map : registry_->List()) {
      maps += fmt::format(" {}@{}", map->name, map->generation);
    }
    spdlog::info(
        "summary: {} requests, {} in flight, replies:{}; localise p50 {:.1f} ms, p90 {:.1f} ms, "
        "p99 {:.1f} ms (n={}); maps:{}; map loads {} ok, {} failed, {} unloaded",
        s.requests, s.in_flight, statuses.empty() ? " none" : statuses, s.latency_p50_ms,
        s.latency_p90_ms, s.latency_p99_ms, s.latency_count, maps.empty() ? " none" : maps,
        registry_->loads(), registry_->load_failures(), registry_->unloads());
    if (zap_ != nullptr) {
      spdlog::info("auth: {} connection(s) admitted, {} refused", zap_->admitted(),
                   zap_->refused());
    }
  }

  // Counts a reply (stats and metrics) and logs it at debug. `request` is null when the
  // request could not be parsed.
  void Record(const char* kind, const v1::Request* request, const v1::Reply& reply,
              Clock::time_point received) {
    RecordAndLog(&stats_, kind, reply, received);
    const bool ok_localise = reply.status() == v1::OK && reply.has_localise();
    metrics_.RecordReply(kind, v1::StatusCode_Name(reply.status()), MapLabel(request, reply),
                         MsSince(received), ok_localise ? &reply.localise().timings() : nullptr);
  }

  // The map a reply concerned, for the metrics' `map` label: one that answered, or the
  // request's when it is loaded; "" otherwise (so made-up names add no series).
  std::string MapLabel(const v1::Request* request, const v1::Reply& reply) const {
    if (reply.has_localise()) return reply.localise().map().name();
    if (reply.has_reload_map()) return reply.reload_map().map().version().name();
    if (request == nullptr) return {};
    const std::string& name = request->has_localise()     ? request->localise().map()
                              : request->has_reload_map() ? request->reload_map().map()
                                                          : std::string();
    return !name.empty() && registry_->Get(name) != nullptr ? name : std::string();
  }

  // Worker mode: one event of the frontend's connection to the broker.
  void ReadMonitorEvent() {
    zmq::message_t event, address;
    if (!monitor_.recv(event, zmq::recv_flags::dontwait)) return;
    if (event.more()) (void)monitor_.recv(address, zmq::recv_flags::dontwait);
    if (event.size() < sizeof(uint16_t)) return;
    uint16_t id = 0;
    std::memcpy(&id, event.data(), sizeof(id));
    if (id == ZMQ_EVENT_CONNECTED) {
      spdlog::info("connected to the broker at {}", options_.connect);
      broker_connected_ = true;
    } else if (id == ZMQ_EVENT_DISCONNECTED) {
      spdlog::warn("lost the broker at {}; reconnecting", options_.connect);
      broker_connected_ = false;
      last_broker_warning_ = Clock::now();
    }
  }

  // Worker mode: says so, every kBrokerWarningInterval, while no broker is connected (one
  // that is down at start, or gone): ZeroMQ keeps trying, the worker keeps waiting.
  void WarnIfNoBroker() {
    if (options_.connect.empty() || broker_connected_) return;
    const Clock::time_point now = Clock::now();
    if (now - last_broker_warning_ < kBrokerWarningInterval) return;
    if (last_broker_warning_ != Clock::time_point{}) {
      spdlog::warn("no broker at {} yet; still trying (is sceneloc-broker running there?)",
                   options_.connect);
    }
    last_broker_warning_ = now;
  }

  // What the metrics read when scraped (any thread).
  ServerGauges Gauges() const {
    const StatsSnapshot s = stats_.Snapshot();
    const SessionCounts sessions = handler_.sessions();
    ServerGauges g;
    g.uptime_s = s.uptime_s;
    g.queue_depth = queue_.size();
    g.in_flight = s.in_flight;
    g.workers = options_.threads;
    g.busy_workers = busy_workers_.load(std::memory_order_relaxed);
    g.sessions = sessions.live;
    g.session_bytes = sessions.memory_bytes;
    g.draining = draining_;
    return g;
  }

  // What the probes judge (any thread).
  ServerHealth Health() const {
    ServerHealth h;
    const Clock::time_point woke(Clock::duration(io_woke_.load(std::memory_order_relaxed)));
    h.io_silence = io_thread_done_ ? std::chrono::hours(1) : Clock::now() - woke;
    h.draining = draining_;
    h.maps_loaded = registry_->List().size();
    h.worker_mode = !options_.connect.empty();
    h.broker_connected = broker_connected_;
    h.broker = options_.connect;
    return h;
  }

  // --- worker threads ---

  void WorkerLoop() {
    zmq::socket_t push(context_, zmq::socket_type::push);
    push.set(zmq::sockopt::linger, -1);
    push.connect(kRepliesEndpoint);
    while (std::optional<std::unique_ptr<Job>> job = queue_.Pop()) {
      Job& j = **job;
      // Handle() turns every exception into an error reply; this catches what is left
      // (the stats or the reply itself out of memory), so no worker ever ends the process.
      try {
        v1::Reply reply;
        const Clock::time_point start = Clock::now();
        if (IsStale(j, start, &reply)) {
          // answered OVERLOADED without the work
        } else if (ParseOnWorker(j, !options_.connect.empty(), &reply)) {
          BusyWorker busy(&busy_workers_);  // counted off even if Handle throws
          handler_.Handle(j.request, j.received, &reply, j.client);
          if (!options_.connect.empty()) AsWorker(j.request, &reply);
          // Workers busy at the end, this one included: fewer than all means idle pool
          // threads may have helped this request (opencv_threads.h, ThreadPool).
          RecordServiceTime(MsSince(start), busy_workers_.load(std::memory_order_relaxed));
        }
        Record(KindName(j.request), &j.request, reply, j.received);
        SendReply(push, j.identity, j.delimited, reply);
      } catch (const zmq::error_t& e) {
        spdlog::error("worker: cannot pass a reply to the I/O thread: {}", e.what());
      } catch (const std::exception& e) {
        spdlog::error("worker: request {} failed outside the handler: {}", j.request.request_id(),
                      e.what());
        try {
          SendReply(push, j.identity, j.delimited,
                    ErrorReply(j.request.request_id(), v1::INTERNAL,
                               std::string("server error: ") + e.what()));
        } catch (...) {
        }
      }
      queued_bytes_ -= static_cast<int64_t>(j.bytes);
    }
  }

  // Worker mode: a map this process does not serve may be served by another worker of the
  // same broker (during a map roll-out the workers of a group are out of step for a
  // while). The reply stays NOT_FOUND, marked retry_elsewhere: sceneloc::Client retries it
  // on a fresh socket (the broker hands the retry to the next worker) and returns the
  // NOT_FOUND only when every retry got one, so a map no worker serves is a clear
  // NOT_FOUND within the retries, not a timeout.
  static void AsWorker(const v1::Request& request, v1::Reply* reply) {
    if (reply->status() != v1::NOT_FOUND || !request.has_localise()) return;
    reply->set_retry_elsewhere(true);
    reply->set_error(reply->error() +
                     " on this worker (another worker of its broker may serve it)");
  }

  // A request that waited for a worker longer than twice limits.max_queue_wait_ms is not
  // worked on: its client gets OVERLOADED now (and is likely to have retried already).
  bool IsStale(const Job& j, Clock::time_point now, v1::Reply* reply) const {
    const double waited_ms = std::chrono::duration<double, std::milli>(now - j.received).count();
    if (waited_ms <= 2.0 * options_.limits.max_queue_wait_ms) return false;
    const uint64_t id = j.parsed ? j.request.request_id() : PeekRequestId(j.raw);
    *reply = OverloadedReply(
        id, {"this request waited " + std::to_string(static_cast<int>(waited_ms)) +
                 " ms for a worker, more than twice limits.max_queue_wait_ms (" +
                 std::to_string(options_.limits.max_queue_wait_ms) + "); it was not worked on",
             QueuedWorkMs() - options_.limits.max_queue_wait_ms + ServiceMs()});
    return true;
  }

  // Counts a worker as busy for its lifetime.
  class BusyWorker {
   public:
    explicit BusyWorker(std::atomic<int>* count) : count_(count) {
      count_->fetch_add(1, std::memory_order_relaxed);
    }
    ~BusyWorker() { count_->fetch_sub(1, std::memory_order_relaxed); }
    BusyWorker(const BusyWorker&) = delete;
    BusyWorker& operator=(const BusyWorker&) = delete;

   private:
    std::atomic<int>* const count_;
  };

  // Folds one request's worker time into the running mean the admission estimate uses:
  // what the request would take with every worker busy. One that ran beside idle workers
  // had their threads' help (a lone JPEG request: about 1.5x faster on 2 threads), which a
  // queue of requests will not get; its time is scaled by threads / busy workers, so the
  // estimate errs on the side of refusing (measured: without it, a burst after a quiet
  // spell was admitted on the lone time and a well-behaved client was then refused
  // OVERLOADED for a second; docs/results.md, issue 10).
  void RecordServiceTime(double wall_ms, int busy_workers) {
    const double ms = wall_ms * options_.threads / std::max(1, busy_workers);
    double old = service_ms_.load(std::memory_order_relaxed);
    while (!service_ms_.compare_exchange_weak(old, old == 0 ? ms : 0.8 * old + 0.2 * ms,
                                              std::memory_order_relaxed)) {
    }
  }

  // Parses a request the I/O thread left unparsed (a large one). False, with `reply` filled,
  // when it is not a valid localise request; true when it is (or was parsed already).
  static bool ParseOnWorker(Job& j, bool worker_mode, v1::Reply* reply) {
    if (j.parsed) return true;
    const bool ok = j.request.ParseFromArray(j.raw.data(), static_cast<int>(j.raw.size()));
    const uint64_t peeked_id = PeekRequestId(j.raw);
    const size_t size = j.raw.size();
    j.raw.rebuild();  // the parsed request holds what is needed
    j.parsed = true;
    if (!ok) {
      *reply =
          ErrorReply(peeked_id, v1::INVALID_ARGUMENT, "request is not a valid sceneloc.v1.Request");
      return false;
    }
    if (j.request.kind_case() != v1::Request::kLocalise) {
      *reply = ErrorReply(j.request.request_id(), v1::INVALID_ARGUMENT,
                          std::string("a ") + KindName(j.request) + " request of " +
                              std::to_string(size) +
                              " bytes: only localise requests may be larger than " +
                              std::to_string(kInlineParseBytes) + " bytes");
      return false;
    }
    if (auto refusal = ProtocolRefusal(j.request, worker_mode)) {
      *reply = *std::move(refusal);
      return false;
    }
    return true;
  }

  const ServerOptions options_;
  MapRegistry* const registry_;
  ServerStats stats_;
  std::unique_ptr<ThreadPool> own_engine_pool_;  // when Start() was given none
  ThreadPool* const engine_pool_;
  const RequestHandler handler_;
  BoundedQueue<std::unique_ptr<Job>> queue_;

  zmq::context_t context_;
  // Owned by the I/O thread once it runs (created and bound by Start's caller before).
  zmq::socket_t frontend_;
  zmq::socket_t replies_;
  zmq::socket_t control_;
  zmq::socket_t loader_push_;  // owned by the loader thread once it runs
  zmq::socket_t monitor_;      // worker mode: frontend_'s events; I/O thread
  Metrics metrics_;
  // When the I/O thread last woke (steady clock ticks), and whether it has ended.
  std::atomic<Clock::rep> io_woke_{Clock::now().time_since_epoch().count()};
  std::atomic<bool> io_thread_done_{false};
  std::atomic<bool> draining_{false};
  std::atomic<bool> broker_connected_{false};  // worker mode
  Clock::time_point last_broker_warning_{};    // worker mode; I/O thread
  // With auth.enabled; declared after context_ so that it (and its socket) ends first.
  std::unique_ptr<ZapHandler> zap_;
  size_t outstanding_ = 0;  // queued or running jobs; I/O thread only
  // Requests queued or running (or waiting for the loader) per connection (ROUTER
  // identity), with the key the connection was made with (auth on; else empty), and per
  // key over all its connections; I/O thread only.
  struct InFlight {
    int count = 0;
    std::string client;
  };
  std::map<std::string, InFlight> in_flight_;
  std::map<std::string, int> key_in_flight_;
  // Bytes of the requests queued or running: added by the I/O thread, taken off by the
  // worker that answered.
  std::atomic<int64_t> queued_bytes_{0};
  // Recent mean time a localise request holds a worker, ms (exponentially weighted; 0
  // until the first one): the admission estimate of limits.max_queue_wait_ms.
  std::atomic<double> service_ms_{0};
  std::atomic<int> busy_workers_{0};  // workers inside a request's Handle()
  // Undelivered replies not yet logged, and when the last such log line was; I/O thread.
  uint64_t undelivered_since_log_ = 0;
  Clock::time_point last_undelivered_log_{};

  std::string endpoint_;  // constant after Bind()
  std::vector<std::thread> workers_;
  std::unique_ptr<MapLoader> loader_;  // set by StartThreads(); stopped by FinishDrain()
  Mutex shutdown_mutex_;               // serialises Shutdown() calls
  std::thread io_thread_ GUARDED_BY(shutdown_mutex_);
  // The operator endpoint (options.metrics_endpoint); declared last so that it stops
  // first, before anything its handlers read.
  std::unique_ptr<HttpEndpoint> http_;
};

}  // namespace

StatusOr<std::unique_ptr<Server>> Server::Start(const ServerOptions& options, MapRegistry* registry,
                                                ThreadPool* engine_pool) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  auto server = std::make_unique<ZmqServer>(options, registry, engine_pool);
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
