// sceneloc-server's settings: configs/server.yaml, every field also a command-line flag.
//
//   server:    maps_dir, watch_maps, reload_debounce_ms, endpoint, threads, queue_capacity,
//              log_level, summary_interval_s, drain_timeout_s
//   limits:    max_message_bytes, max_image_side, max_image_pixels, max_keypoints, max_top_k,
//              max_request_ms, max_jpeg_scans, max_map_bytes, max_in_flight_per_client,
//              max_in_flight_per_key, max_queued_bytes, max_decode_bytes, max_queue_wait_ms
//   auth:      enabled, server_key, clients
//   sessions:  max_sessions, idle_timeout_s, max_state_bytes
//   keep_frames: dir, quota_bytes, min_unknown_frames, max_pending_bytes
//   matching:, sequence:  as configs/match.yaml (common/config/config.h)
//
// Each field is declared once, with its range, unit and help (server_options.cc,
// common/util/settings.h): the file reader, Validate(), the flags and configs/server.yaml
// all come from that declaration.
//
// Strict like common/config: an unknown section or key, a wrong type or an out-of-range
// value is an error naming the source and the key.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/matching/localiser.h"
#include "common/util/status.h"
#include "server/frame_keeper.h"
#include "server/session_store.h"

namespace sceneloc {

// Caps on untrusted requests. Each refusal is an error reply and a counter, never a crash.
struct RequestLimits {
  // Largest request the server reads, bytes. A larger one gets RESOURCE_EXHAUSTED; one
  // over twice this is cut off by ZeroMQ itself (ZMQ_MAXMSGSIZE) and the peer disconnected.
  int64_t max_message_bytes = 8 << 20;
  // Largest image width or height a request may carry, pixels: a JPEG's (read from its
  // header before decoding) and a feature set's. Below the engine's kDefaultMaxImageSide
  // (common/features/feature_set.h): a server decodes untrusted JPEGs.
  int max_image_side = 4096;
  // Largest width x height of a JPEG, pixels (decoding allocates 3 bytes per pixel).
  int64_t max_image_pixels = 16 << 20;
  // Most keypoints in a feature-set request.
  int max_keypoints = 8192;
  // Most ranked locations a request may ask for.
  int max_top_k = 100;
  // A localise request's time budget from its arrival (queueing included), milliseconds:
  // past it, the request ends with DEADLINE_EXCEEDED at the next stage boundary, saying
  // where and what each stage took.
  int max_request_ms = 5000;
  // Most scans in a JPEG (a baseline JPEG has 1, a progressive one about 10): decoding
  // passes over the whole image once per scan.
  int max_jpeg_scans = 64;
  // Largest map file the server reads, bytes; larger files in maps_dir are logged, counted
  // and skipped unread (a 200-location map is about 7 MB, a 20,000-location one 0.7 GB).
  int64_t max_map_bytes = int64_t{4} << 30;
  // Requests one connection may have queued or running at once; one more gets OVERLOADED
  // (a client that floods cannot fill the queue ahead of the others by itself).
  int max_in_flight_per_client = 8;
  // With auth on: requests all the connections of one key may have queued or running at
  // once; one more gets OVERLOADED. A client that opens many connections (a few hundred
  // requests sent and never read) still counts as one. Give each robot its own key
  // (docs/security.md), or raise this for keys that robots share.
  int max_in_flight_per_key = 8;
  // Bytes of the requests queued or running at once, all connections together; a request
  // that would pass it gets OVERLOADED (so 64 requests of 8 MiB cannot pin 512 MiB).
  int64_t max_queued_bytes = int64_t{64} << 20;
  // Memory that the JPEG decodes running at once may hold together, bytes (each decode's
  // peak is estimated from its header: 3 bytes a pixel, plus 2 a pixel per component for a
  // progressive JPEG). A decode that does not fit waits for one to finish, up to its
  // request's deadline; a JPEG that could never fit gets RESOURCE_EXHAUSTED. The default
  // holds one largest progressive JPEG (4096 x 4096: 150 MiB) or many ordinary ones.
  int64_t max_decode_bytes = int64_t{192} << 20;
  // Longest a request should wait for a worker, milliseconds. A request arriving when the
  // work queued ahead of it is estimated to take longer (queued requests x the recent mean
  // time a request holds a worker / workers) gets OVERLOADED at once, and a request that
  // has waited longer than twice this when a worker takes it is answered OVERLOADED
  // without being worked on: under overload clients learn it in milliseconds instead of
  // waiting seconds, and the requests that are admitted are answered fresh.
  int max_queue_wait_ms = 500;

  Status Validate() const;
};

// Who may connect (server/zap_handler.h). Off by default; docs/security.md has a worked
// example.
struct AuthOptions {
  // CURVE encryption and the authorised-clients check on the server socket.
  bool enabled = false;
  // The server's key pair (sceneloc keygen NAME writes NAME.key and NAME.pub).
  std::string server_key;
  // The authorised-clients file (common/keys/keys.h); re-read on SIGHUP.
  std::string clients;

  Status Validate() const;
};

struct ServerOptions {
  // Folder of map files (*.scnl); each is served under its file stem.
  std::string maps_dir = "maps";
  // Follow maps_dir's changes (inotify): a map file written or renamed into place is
  // loaded, a deleted one unloaded. Off: only SIGHUP and ReloadMap requests reload.
  bool watch_maps = true;
  // A map file's changes are acted on once it has been quiet this long, milliseconds
  // (coalesces the events of one write or copy).
  int reload_debounce_ms = 100;
  // ZeroMQ endpoint the ROUTER socket binds, e.g. tcp://*:5555 or tcp://127.0.0.1:*.
  std::string endpoint = "tcp://*:5555";
  // Worker mode: connect to a broker's backend (sceneloc-broker --backend) instead of
  // binding `endpoint`, e.g. tcp://broker-host:5556. Clients talk to the broker's frontend
  // and do not change; any number of workers may connect and leave. Empty: bind.
  std::string connect;
  // HOST:PORT of the operator endpoint: Prometheus /metrics and the /healthz and /readyz
  // probes over HTTP (server/health.h), e.g. 127.0.0.1:9464 (port 0: any free port).
  // Empty: none.
  std::string metrics_endpoint;
  // Worker threads that localise requests (also the engine's ParallelFor width).
  int threads = 2;
  // Requests waiting for a worker at most; one more gets an immediate OVERLOADED reply.
  int queue_capacity = 64;
  // spdlog level: trace, debug, info, warn, error, critical, off.
  std::string log_level = "info";
  // Seconds between summary log lines at info (0 = none).
  double summary_interval_s = 60;
  // On SIGTERM, wait at most this long for in-flight requests, seconds.
  double drain_timeout_s = 10;
  RequestLimits limits;
  AuthOptions auth;
  SessionOptions sessions;
  KeepFramesOptions keep_frames;
  MatchOptions matching;

  Status Validate() const;
};

// Reads a settings file over `options` (which holds the defaults on entry).
Status LoadServerOptions(const std::string& path, ServerOptions* options);
// The same from YAML text; `name` names the source in errors.
Status ParseServerOptions(const std::string& yaml, const std::string& name, ServerOptions* options);

// A command-line flag for one settings field: "--threads" sets server.threads.
struct ServerFlag {
  std::string flag;     // without dashes, e.g. "threads", "maps", "s-min"
  std::string section;  // "server", "limits" or "matching"
  std::string key;      // e.g. "threads", "maps_dir", "s_min"
  std::string help;
};
// Every field's flag, in file order.
std::vector<ServerFlag> ServerFlags();
// Sets the fields of `flags` from their command-line text, each with the file's type and
// range checks, then validates the whole options once (so flags that depend on each other,
// like --auth and --server-key, may come in any order). Errors name the flags; on an error
// *options is unchanged.
Status ApplyServerFlags(const std::vector<std::pair<ServerFlag, std::string>>& flags,
                        ServerOptions* options);
// ApplyServerFlags of one flag.
Status ApplyServerFlag(const ServerFlag& flag, const std::string& value, ServerOptions* options);

// The settings as YAML, in the file's layout (logged at start-up).
std::string ServerOptionsToYaml(const ServerOptions& options);

// `options` as a documented settings file (sceneloc-server --print-config). For the
// defaults it is configs/server.yaml, exactly (tests/server/server_options_test checks it).
std::string DocumentedServerSettings(const ServerOptions& options = ServerOptions());

}  // namespace sceneloc
