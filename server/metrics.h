// The server's Prometheus metrics (served as text by server.metrics_endpoint's /metrics).
//
// Two kinds: what happens is counted as it happens (requests by kind, status and map;
// latency histograms end to end and per engine stage; undelivered replies), and what the
// server holds is read when scraped (queue depth, busy workers, live sessions, the maps
// loaded with their generation, map loads and failures), so a scrape never sees a stale
// gauge and the request path never updates one.
//
// Label values are bounded: `kind` and `status` come from the protocol's enums, and `map`
// is a loaded map's name or "" (a request naming a map that is not loaded is counted
// under ""), so a client cannot grow the series by inventing names.
//
// Thread-safe: every method may be called from any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "proto/sceneloc.pb.h"
#include "server/frame_keeper.h"
#include "server/map_registry.h"

namespace sceneloc {

// What the server holds when scraped (filled by the server).
struct ServerGauges {
  double uptime_s = 0;
  size_t queue_depth = 0;     // requests waiting for a worker
  uint64_t in_flight = 0;     // requests received and not yet answered
  int workers = 0;            // server.threads
  int busy_workers = 0;       // workers running a request now
  size_t sessions = 0;        // live sessions
  size_t session_bytes = 0;   // their memory
  bool draining = false;      // shutting down
  bool keeps_frames = false;  // keep_frames.dir is set: `kept` holds its counts
  KeepFramesCounts kept;
};

class Metrics {
 public:
  Metrics();
  ~Metrics();

  // A reply left: `kind` is the request kind ("localise", "list_maps", "reload_map",
  // "stats", or "request" when it could not be parsed), `status` the wire status name,
  // `map` the loaded map it concerned ("" for none). `timings` (a successful localise
  // reply's) adds each stage to the stage histograms; may be null.
  void RecordReply(const std::string& kind, const std::string& status, const std::string& map,
                   double latency_ms, const v1::Timings* timings);
  // A reply could not be delivered (the client had gone or stopped reading).
  void RecordUndelivered();

  // Prometheus text exposition format 0.0.4: the counted metrics, then those of `gauges`
  // and `maps`.
  std::string Render(const ServerGauges& gauges, const MapRegistry& maps) const;

  static constexpr const char* kContentType = "text/plain; version=0.0.4; charset=utf-8";

 private:
  struct Families;
  std::unique_ptr<Families> families_;
};

}  // namespace sceneloc
