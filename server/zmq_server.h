// Internal to server/: the Server implementation (server.h has the contract and the
// picture). Include server/server.h, not this.
//
// One class, its member functions in a file per seam:
//   server.cc            start-up: sockets, threads, the operator endpoint; Server::Start
//   server_io.cc         the I/O thread's loop: the ROUTER, replies forwarded, the broker
//   server_dispatch.cc   a request read, checked and answered inline, queued or refused
//   server_admission.cc  the admission limits and the queue-wait estimate
//   server_workers.cc    the worker threads
//   server_shutdown.cc   Shutdown() and the drain
//   server_report.cc     replies counted and logged, the summary line, metrics and probes
//
// Threads: the I/O thread owns the ROUTER (frontend_), the replies PULL, the control PULL
// and the monitor, and the members marked "I/O thread"; each worker and the loader own
// their PUSH. What several threads touch is an atomic, or guarded by a mutex and says so.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>
#include <zmq.hpp>

#include "common/util/mutex.h"
#include "common/util/status.h"
#include "common/util/thread_annotations.h"
#include "common/util/thread_pool.h"
#include "proto/sceneloc.pb.h"
#include "server/bounded_queue.h"
#include "server/health.h"
#include "server/http_endpoint.h"
#include "server/map_loader.h"
#include "server/map_registry.h"
#include "server/metrics.h"
#include "server/replies.h"
#include "server/request_handler.h"
#include "server/server.h"
#include "server/server_options.h"
#include "server/server_stats.h"
#include "server/zap_handler.h"

namespace sceneloc {

class ZmqServer final : public Server {
 public:
  using Clock = std::chrono::steady_clock;

  ZmqServer(const ServerOptions& options, MapRegistry* registry, ThreadPool* engine_pool,
            std::unique_ptr<FrameKeeper> keeper = nullptr);
  ~ZmqServer() override { Shutdown(); }

  // Start-up, in this order (Server::Start). Binds (or, in worker mode, connects) the
  // frontend and the inproc sockets; with auth on, starts the ZAP handler first.
  Status Bind();
  // Serves options.metrics_endpoint (server/health.h), when set.
  Status StartOperatorHttp();
  // Starts the map loader, the workers and the I/O thread.
  Status StartThreads() EXCLUDES(shutdown_mutex_);

  std::string endpoint() const override { return endpoint_; }
  std::string metrics_endpoint() const override;
  void ReloadAll() override;
  bool WaitForLoader(std::chrono::milliseconds timeout) override;
  void Shutdown() override EXCLUDES(shutdown_mutex_);

 private:
  // Where the workers and the loader push their replies (the I/O thread pulls), and where
  // Shutdown() tells the I/O thread to drain.
  static constexpr char kRepliesEndpoint[] = "inproc://sceneloc-replies";
  static constexpr char kControlEndpoint[] = "inproc://sceneloc-control";
  // Identity + empty delimiter + request is the most a valid request has.
  static constexpr size_t kMaxFrames = 3;
  // Requests up to this size are parsed on the I/O thread (list_maps, stats, reload_map
  // and most feature sets: microseconds); larger ones, which only a localise request may
  // be, are parsed by the worker that takes them, so a burst of 8 MiB messages never
  // holds up the I/O thread.
  static constexpr size_t kInlineParseBytes = 64 << 10;
  // reload_map requests waiting for the loader at once (reloads of one map coalesce into
  // one load); more get OVERLOADED.
  static constexpr size_t kMaxWaitingReloads = 16;

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

  // --- I/O thread (server_io.cc) ---

  // Polls the sockets until a drain has ended (no request outstanding, or its deadline),
  // then FinishDrain()s.
  void IoLoop();
  Clock::duration SummaryInterval() const;
  // How long the poll may sleep: until the drain deadline or the next summary, at most
  // kMaxPollWait.
  std::chrono::milliseconds PollTimeout(const std::optional<Clock::time_point>& deadline,
                                        Clock::time_point next_summary) const;
  // Reads one multipart message, keeping at most kMaxFrames frames (the rest are read and
  // dropped so the socket stays in step).
  Incoming ReceiveFrames();
  // Moves one finished reply from a worker or the loader to its client.
  void ForwardReply();
  // Sends [identity][empty?][reply] to a client.
  void ToClient(zmq::message_t& identity, bool delimited, const v1::Reply& reply);
  // Sends one reply's frames on the ROUTER without ever blocking the I/O thread. The ROUTER
  // is ZMQ_ROUTER_MANDATORY, so a reply that cannot be delivered is known rather than
  // silently dropped: the client has gone (EHOSTUNREACH), or it has stopped reading and
  // its connection holds ZeroMQ's high-water mark of unread replies (EAGAIN). Such a reply
  // is dropped, counted (stats: replies_undelivered) and logged at most once a second.
  void Deliver(std::vector<zmq::message_t>& frames);
  // Worker mode: one event of the frontend's connection to the broker.
  void ReadMonitorEvent();
  // Worker mode: says so, every kBrokerWarningInterval, while no broker is connected (one
  // that is down at start, or gone): ZeroMQ keeps trying, the worker keeps waiting.
  void WarnIfNoBroker();

  // --- I/O thread: requests (server_dispatch.cc) ---

  // Reads one request and answers it (refused, or answered inline) or hands it on.
  // `draining`: a request that passes its checks gets UNAVAILABLE.
  void ReadRequest(bool draining);
  // The name of the key a message came with (set by the ZAP handler); empty without one.
  static std::string UserOf(zmq::message_t& payload);
  // With auth on: the request's key (its name, set by the ZAP handler) must still be in the
  // clients file, and reload_map needs one marked admin. `request` is null when the
  // request is too large to be parsed here (then it can only be a localise request).
  Status CheckPermission(const std::string& user, const v1::Request* request) const;
  // Answers a cheap request inline, hands a reload to the loader, queues the rest for the
  // workers when admitted; else OVERLOADED.
  void Dispatch(std::unique_ptr<Job> job);
  // Hands a ReloadMap request to the loader thread, which answers it through loader_push_.
  void DispatchReload(std::unique_ptr<Job> job);

  // --- admission (server_admission.cc) ---

  // The recent mean time a request holds a worker, ms; 100 before the first one. Any
  // thread.
  double ServiceMs() const;
  // The work waiting for a worker ahead of a new request, estimated in ms of the pool's
  // time: for a large one (parsed on a worker) everything queued over every worker; for a
  // small one only the small requests queued, over the workers not holding a large one (it
  // is taken ahead of large ones). Any thread.
  double QueuedWorkMs(bool large) const;
  // Admits when the work queued ahead of a new request is estimated to take no longer than
  // limits.max_queue_wait_ms; else the estimate and the limit, and as the retry hint the
  // time for the queue to drain below the limit.
  Refusal WaitRefusal(bool large) const;
  static std::string ConnectionKey(const zmq::message_t& identity);
  // Admits a request of `bytes` from `connection` (with auth on, made with the key named
  // `client`) unless it would pass a per-connection, per-key or byte limit; else which,
  // with the figures. The byte limit binds large requests only: small ones hold at most
  // kInlineParseBytes each (queue_capacity of them), and a flood of large ones must not
  // refuse them. Each limit is freed by a running request finishing: the retry hint.
  // I/O thread.
  Refusal AdmissionRefusal(const std::string& connection, const std::string& client, size_t bytes,
                           bool large) const;
  // Counts an admitted request against its connection and key until Released(). I/O
  // thread.
  void Track(const std::string& connection, const std::string& client);
  void Released(const std::string& connection);
  // Folds one request's worker time into the running mean the admission estimate uses
  // (service_ms_). Any thread.
  void RecordServiceTime(double wall_ms, int busy_workers);

  // --- worker threads (server_workers.cc) ---

  void WorkerLoop();
  // Worker mode: a NOT_FOUND localise reply is marked retry_elsewhere (another worker of
  // the same broker may serve the map).
  static void AsWorker(const v1::Request& request, v1::Reply* reply);
  // A request that waited for a worker longer than twice limits.max_queue_wait_ms is not
  // worked on: true, with `reply` set to OVERLOADED.
  bool IsStale(const Job& j, Clock::time_point now, v1::Reply* reply) const;
  // Parses a request the I/O thread left unparsed (a large one). False, with `reply` filled,
  // when it is not a valid localise request or its feature set has more than
  // limits.max_keypoints keypoints (counted before the parse); true when it is valid (or
  // was parsed already).
  bool ParseOnWorker(Job& j, bool worker_mode, v1::Reply* reply) const;

  // --- shutdown (server_shutdown.cc) ---

  // On the I/O thread once the drain has ended: answers the jobs still queued UNAVAILABLE,
  // joins the workers, stops the loader, forwards the replies they left, logs the summary
  // and closes the I/O thread's sockets.
  void FinishDrain();

  // --- reporting (server_report.cc) ---

  static double MsSince(Clock::time_point t);
  // The summary log line: requests, replies by status, latency percentiles, maps, loads.
  void LogSummary() const;
  // Counts a reply (stats and metrics) and logs it at debug. `request` is null when the
  // request could not be parsed. Any thread.
  void Record(const char* kind, const v1::Request* request, const v1::Reply& reply,
              Clock::time_point received);
  // The map a reply concerned, for the metrics' `map` label: one that answered, or the
  // request's when it is loaded; "" otherwise (so made-up names add no series).
  std::string MapLabel(const v1::Request* request, const v1::Reply& reply) const;
  // What the metrics read when scraped (any thread).
  ServerGauges Gauges() const;
  // What the probes judge (any thread).
  ServerHealth Health() const;

  // Constant after construction.
  const ServerOptions options_;
  MapRegistry* const registry_;
  ServerStats stats_;                            // thread-safe
  std::unique_ptr<ThreadPool> own_engine_pool_;  // when Start() was given none
  ThreadPool* const engine_pool_;
  const RequestHandler handler_;              // thread-safe
  BoundedQueue<std::unique_ptr<Job>> queue_;  // thread-safe

  zmq::context_t context_;
  // Owned by the I/O thread once it runs (created and bound by Start's caller before).
  zmq::socket_t frontend_;
  zmq::socket_t replies_;
  zmq::socket_t control_;
  zmq::socket_t loader_push_;  // owned by the loader thread once it runs
  zmq::socket_t monitor_;      // worker mode: frontend_'s events; I/O thread
  Metrics metrics_;            // thread-safe
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

  std::string endpoint_;               // constant after Bind()
  std::vector<std::thread> workers_;   // set by StartThreads(); joined by FinishDrain()
  std::unique_ptr<MapLoader> loader_;  // set by StartThreads(); stopped by FinishDrain()
  Mutex shutdown_mutex_;               // serialises Shutdown() calls
  std::thread io_thread_ GUARDED_BY(shutdown_mutex_);
  // The operator endpoint (options.metrics_endpoint); declared last so that it stops
  // first, before anything its handlers read.
  std::unique_ptr<HttpEndpoint> http_;
};

}  // namespace sceneloc
