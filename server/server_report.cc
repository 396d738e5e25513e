// What the server says about itself: every reply counted (stats, metrics) and logged at
// debug, the periodic and final summary line, the gauges the metrics read and what the
// health probes judge.
#include <spdlog/spdlog.h>

#include "server/zmq_server.h"

namespace sceneloc {
namespace {

void RecordAndLog(ServerStats* stats, const char* kind, const v1::Reply& reply, double ms) {
  const std::string& status = v1::StatusCode_Name(reply.status());
  stats->RecordReply(status, reply.kind_case() == v1::Reply::kLocalise, ms);
  if (reply.status() == v1::OK) {
    spdlog::debug("request {} {}: OK in {:.1f} ms", reply.request_id(), kind, ms);
  } else {
    spdlog::debug("request {} {}: {} in {:.1f} ms: {}", reply.request_id(), kind, status, ms,
                  reply.error());
  }
}

}  // namespace

double ZmqServer::MsSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

void ZmqServer::LogSummary() const {
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
    spdlog::info("auth: {} connection(s) admitted, {} refused", zap_->admitted(), zap_->refused());
  }
}

void ZmqServer::Record(const char* kind, const v1::Request* request, const v1::Reply& reply,
                       Clock::time_point received) {
  RecordAndLog(&stats_, kind, reply, MsSince(received));
  const bool ok_localise = reply.status() == v1::OK && reply.has_localise();
  metrics_.RecordReply(kind, v1::StatusCode_Name(reply.status()), MapLabel(request, reply),
                       MsSince(received), ok_localise ? &reply.localise().timings() : nullptr);
}

std::string ZmqServer::MapLabel(const v1::Request* request, const v1::Reply& reply) const {
  if (reply.has_localise()) return reply.localise().map().name();
  if (reply.has_reload_map()) return reply.reload_map().map().version().name();
  if (request == nullptr) return {};
  const std::string& name = request->has_localise()     ? request->localise().map()
                            : request->has_reload_map() ? request->reload_map().map()
                                                        : std::string();
  return !name.empty() && registry_->Get(name) != nullptr ? name : std::string();
}

ServerGauges ZmqServer::Gauges() const {
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
  if (const FrameKeeper* keeper = handler_.keeper(); keeper != nullptr) {
    g.keeps_frames = true;
    g.kept = keeper->Counts();
  }
  return g;
}

ServerHealth ZmqServer::Health() const {
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

}  // namespace sceneloc
