#include "server/server_options.h"

#include <spdlog/common.h>

#include <algorithm>

#include "common/config/config.h"
#include "common/keys/keys.h"
#include "server/http_endpoint.h"

namespace sceneloc {
namespace {

// Every settable field of the server: its own server: and limits: sections, then the
// engine's matching: section (the same keys as configs/match.yaml).
SettingTable Fields(ServerOptions* o) {
  RequestLimits* l = &o->limits;
  SettingTable table = {
      {"server", "maps_dir", &o->maps_dir, 0, 0,
       "folder of map files (*.scnl), served by file stem", "maps"},
      {"server", "watch_maps", &o->watch_maps, 0, 0,
       "load/unload maps as their files change in maps_dir (inotify)"},
      {"server", "reload_debounce_ms", &o->reload_debounce_ms, 0, 60000,
       "act on a map file's changes once quiet this long, ms"},
      {"server", "endpoint", &o->endpoint, 0, 0, "ZeroMQ endpoint to bind, e.g. tcp://*:5555"},
      {"server", "connect", &o->connect, 0, 0,
       "worker mode: connect to a sceneloc-broker backend, e.g. tcp://host:5556, instead of "
       "binding endpoint"},
      {"server", "metrics_endpoint", &o->metrics_endpoint, 0, 0,
       "HOST:PORT for Prometheus /metrics and the /healthz, /readyz probes, e.g. "
       "127.0.0.1:9464 (empty = none)"},
      {"server", "threads", &o->threads, 1, 256, "worker threads"},
      {"server", "queue_capacity", &o->queue_capacity, 1, 1000000,
       "requests waiting for a worker at most; more get OVERLOADED"},
      {"server", "log_level", &o->log_level, 0, 0,
       "trace, debug, info, warn, error, critical, off"},
      {"server", "summary_interval_s", &o->summary_interval_s, 0, 1e6,
       "seconds between summary log lines (0 = none)", "summary-interval"},
      {"server", "drain_timeout_s", &o->drain_timeout_s, 0, 3600,
       "seconds to wait for in-flight requests on SIGTERM", "drain-timeout"},
      {"limits", "max_message_bytes", &l->max_message_bytes, 1024, 1e9, "largest request, bytes"},
      {"limits", "max_image_side", &l->max_image_side, 16, 65536,
       "largest JPEG width or height, pixels"},
      {"limits", "max_image_pixels", &l->max_image_pixels, 256, 1e10,
       "largest JPEG width x height, pixels"},
      {"limits", "max_keypoints", &l->max_keypoints, 1, 1000000, "most keypoints in a feature set"},
      {"limits", "max_top_k", &l->max_top_k, 1, 1000, "most ranked locations per request"},
      {"limits", "max_request_ms", &l->max_request_ms, 1, 3600000,
       "a localise request's time budget from its arrival, ms (then DEADLINE_EXCEEDED)"},
      {"limits", "max_jpeg_scans", &l->max_jpeg_scans, 1, 100000,
       "most scans in a JPEG (progressive JPEGs have ~10); more is a decompression bomb"},
      {"limits", "max_map_bytes", &l->max_map_bytes, 1024, 1e15,
       "largest map file read, bytes; larger ones are skipped unread"},
      {"limits", "max_in_flight_per_client", &l->max_in_flight_per_client, 1, 1000000,
       "requests one connection may have queued or running; more get OVERLOADED"},
      {"limits", "max_in_flight_per_key", &l->max_in_flight_per_key, 1, 1000000,
       "with auth: requests all connections of one key may have queued or running"},
      {"limits", "max_queued_bytes", &l->max_queued_bytes, 1024, 1e15,
       "bytes of requests queued or running, all connections; more get OVERLOADED"},
      {"limits", "max_decode_bytes", &l->max_decode_bytes, 1 << 20, 1e15,
       "memory the JPEG decodes running at once may hold together, bytes"},
      {"limits", "max_queue_wait_ms", &l->max_queue_wait_ms, 1, 3600000,
       "longest estimated wait for a worker before OVERLOADED, ms"},
      {"auth", "enabled", &o->auth.enabled, 0, 0,
       "CURVE encryption, admitting only the keys in auth.clients", "auth"},
      {"auth", "server_key", &o->auth.server_key, 0, 0, "the server's key pair file (.key)",
       "server-key"},
      {"auth", "clients", &o->auth.clients, 0, 0, "authorised client keys file (re-read on SIGHUP)",
       "auth-clients"},
      {"sessions", "max_sessions", &o->sessions.max_sessions, 1, 1e9,
       "live sessions at most; a new one beyond drops the least recently used", "max-sessions"},
      {"sessions", "idle_timeout_s", &o->sessions.idle_timeout_s, 1e-3, 1e9,
       "a session unused this long is dropped, seconds", "session-idle-timeout"},
      {"sessions", "max_state_bytes", &o->sessions.max_state_bytes, 1, 1e15,
       "the sessions' filter states together at most, bytes; past it the least recently used "
       "are dropped",
       "max-session-bytes"},
  };
  for (SettingField& f : MatchSettingTable(&o->matching)) {
    f.help = f.section + "." + f.key + " (configs/match.yaml)";
    table.push_back(std::move(f));
  }
  return table;
}

}  // namespace

Status RequestLimits::Validate() const {
  if (max_message_bytes < 1024) return InvalidArgument("max_message_bytes must be >= 1024");
  if (max_image_side < 16) return InvalidArgument("max_image_side must be >= 16");
  if (max_image_pixels < 256) return InvalidArgument("max_image_pixels must be >= 256");
  if (max_keypoints < 1) return InvalidArgument("max_keypoints must be >= 1");
  if (max_top_k < 1) return InvalidArgument("max_top_k must be >= 1");
  if (max_map_bytes < 1024) return InvalidArgument("max_map_bytes must be >= 1024");
  if (max_jpeg_scans < 1) return InvalidArgument("max_jpeg_scans must be >= 1");
  if (max_request_ms < 1) return InvalidArgument("max_request_ms must be >= 1");
  if (max_in_flight_per_client < 1) return InvalidArgument("max_in_flight_per_client must be >= 1");
  if (max_in_flight_per_key < 1) return InvalidArgument("max_in_flight_per_key must be >= 1");
  if (max_decode_bytes < (1 << 20)) return InvalidArgument("max_decode_bytes must be >= 1 MiB");
  if (max_queue_wait_ms < 1) return InvalidArgument("max_queue_wait_ms must be >= 1");
  if (max_queued_bytes < max_message_bytes) {
    return InvalidArgument("max_queued_bytes (" + std::to_string(max_queued_bytes) +
                           ") must be >= max_message_bytes (" + std::to_string(max_message_bytes) +
                           "), or the largest request could never be queued");
  }
  return Status::Ok();
}

Status AuthOptions::Validate() const {
  if (!enabled) return Status::Ok();
  if (server_key.empty())
    return InvalidArgument("auth.enabled needs auth.server_key (a .key file)");
  if (clients.empty()) return InvalidArgument("auth.enabled needs auth.clients (a clients file)");
  if (!CurveAvailable()) return Unimplemented("auth.enabled: this libzmq was built without CURVE");
  return Status::Ok();
}

Status ServerOptions::Validate() const {
  if (maps_dir.empty()) return InvalidArgument("maps_dir must be set");
  if (endpoint.empty()) return InvalidArgument("endpoint must be set");
  if (reload_debounce_ms < 0) return InvalidArgument("reload_debounce_ms must be >= 0");
  if (threads < 1) return InvalidArgument("threads must be >= 1");
  if (queue_capacity < 1) return InvalidArgument("queue_capacity must be >= 1");
  if (spdlog::level::from_str(log_level) == spdlog::level::off && log_level != "off") {
    return InvalidArgument("log_level '" + log_level +
                           "' is not one of trace, debug, info, warn, error, critical, off");
  }
  if (!(summary_interval_s >= 0)) return InvalidArgument("summary_interval_s must be >= 0");
  if (!(drain_timeout_s >= 0)) return InvalidArgument("drain_timeout_s must be >= 0");
  SCENELOC_RETURN_IF_ERROR(limits.Validate());
  SCENELOC_RETURN_IF_ERROR(auth.Validate());
  if (!metrics_endpoint.empty()) {
    const Status address = ValidateHttpAddress(metrics_endpoint);
    if (!address.ok()) return InvalidArgument("server.metrics_endpoint: " + address.message());
  }
  if (!connect.empty() && auth.enabled) {
    return InvalidArgument(
        "server.connect (worker mode) cannot be combined with auth.enabled: clients "
        "authenticate with the server they connect to, which is then the broker");
  }
  SCENELOC_RETURN_IF_ERROR(sessions.Validate());
  return matching.Validate();
}

Status ParseServerOptions(const std::string& yaml, const std::string& name,
                          ServerOptions* options) {
  ServerOptions updated = *options;
  SCENELOC_RETURN_IF_ERROR(ApplySettings(yaml, name, Fields(&updated)));
  const Status valid = updated.Validate();
  if (!valid.ok()) return InvalidArgument(name + ": " + valid.message());
  *options = updated;
  return Status::Ok();
}

Status LoadServerOptions(const std::string& path, ServerOptions* options) {
  SCENELOC_ASSIGN_OR_RETURN(const std::string text, ReadSettingsFile(path));
  return ParseServerOptions(text, path, options);
}

std::vector<ServerFlag> ServerFlags() {
  ServerOptions scratch;
  std::vector<ServerFlag> flags;
  for (const SettingField& f : Fields(&scratch)) {
    flags.push_back({f.FlagName(), f.section, f.key, f.help});
  }
  return flags;
}

Status ApplyServerFlags(const std::vector<std::pair<ServerFlag, std::string>>& flags,
                        ServerOptions* options) {
  ServerOptions updated = *options;
  const SettingTable fields = Fields(&updated);
  std::string names;
  for (const auto& given : flags) {
    const ServerFlag& flag = given.first;  // not a structured binding: the lambda captures it
    const std::string where = "--" + flag.flag;
    const auto it = std::find_if(fields.begin(), fields.end(), [&](const SettingField& f) {
      return flag.section == f.section && flag.key == f.key;
    });
    if (it == fields.end()) return InvalidArgument(where + " is not a server setting");
    SCENELOC_RETURN_IF_ERROR(ApplySetting(*it, given.second, where));
    names += (names.empty() ? "" : ", ") + where;
  }
  const Status valid = updated.Validate();
  if (!valid.ok()) return InvalidArgument(names + ": " + valid.message());
  *options = updated;
  return Status::Ok();
}

Status ApplyServerFlag(const ServerFlag& flag, const std::string& value, ServerOptions* options) {
  return ApplyServerFlags({{flag, value}}, options);
}

std::string ServerOptionsToYaml(const ServerOptions& options) {
  ServerOptions copy = options;
  return SettingsToYaml(Fields(&copy));
}

}  // namespace sceneloc
