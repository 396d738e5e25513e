#include "server/server_options.h"

#include <algorithm>

#include "common/config/config.h"
#include "common/features/feature_set.h"
#include "common/keys/keys.h"
#include "server/http_endpoint.h"

namespace sceneloc {
namespace {

// The server: section, bound to `o`.
SettingTable ServerSection(ServerOptions* o) {
  return {
      Setting("server", "maps_dir", &o->maps_dir)
          .Help("every *.scnl here is served under its file stem")
          .Flag("maps"),
      Setting("server", "watch_maps", &o->watch_maps)
          .Help("follow the folder: new/replaced files load, deleted ones unload (inotify)"),
      Setting("server", "reload_debounce_ms", &o->reload_debounce_ms)
          .Range(0, 60000)
          .Unit("ms")
          .Help("act on a map file's changes once it has been quiet this long"),
      Setting("server", "endpoint", &o->endpoint).Help("ZeroMQ ROUTER endpoint to bind"),
      Setting("server", "connect", &o->connect)
          .Help("worker mode: connect to a sceneloc-broker backend, e.g. tcp://host:5556, "
                "instead of binding endpoint (\"\" = bind)"),
      Setting("server", "metrics_endpoint", &o->metrics_endpoint)
          .Help("HOST:PORT for Prometheus /metrics, /healthz, /readyz (\"\" = none)"),
      Setting("server", "threads", &o->threads)
          .Range(1, 256)
          .Help("worker threads (also the engine's ParallelFor width)"),
      Setting("server", "queue_capacity", &o->queue_capacity)
          .Range(1, 1000000)
          .Help("requests waiting for a worker; more get OVERLOADED at once"),
      Setting("server", "log_level", &o->log_level)
          .Choices({"trace", "debug", "info", "warn", "error", "critical", "off"})
          .Help("debug logs a line per request"),
      Setting("server", "summary_interval_s", &o->summary_interval_s)
          .Range(0, 1e6)
          .Unit("s")
          .Help("between summary lines at info (0 = none)")
          .Flag("summary-interval"),
      Setting("server", "drain_timeout_s", &o->drain_timeout_s)
          .Range(0, 3600)
          .Unit("s")
          .Help("on SIGTERM, wait this long for in-flight requests")
          .Flag("drain-timeout"),
  };
}

// The limits: section.
SettingTable LimitsSettings(RequestLimits* l) {
  return {
      Setting("limits", "max_message_bytes", &l->max_message_bytes)
          .Range(1024, 1e9)
          .Unit("bytes")
          .Help("larger requests get RESOURCE_EXHAUSTED (over 2x: disconnected)"),
      Setting("limits", "max_image_side", &l->max_image_side)
          .Range(kMinImageSide, kMaxImageSideSetting)
          .Unit("pixels")
          .Help("JPEG width/height cap, read from the header before decoding"),
      Setting("limits", "max_image_pixels", &l->max_image_pixels)
          .Range(256, 1e10)
          .Unit("pixels")
          .Help("JPEG width x height cap"),
      Setting("limits", "max_keypoints", &l->max_keypoints)
          .Range(1, 1000000)
          .Help("keypoints per feature-set request"),
      Setting("limits", "max_top_k", &l->max_top_k)
          .Range(1, 1000)
          .Help("ranked locations a request may ask for"),
      Setting("limits", "max_request_ms", &l->max_request_ms)
          .Range(1, 3600000)
          .Unit("ms")
          .Help("a localise request's time budget from arrival (then DEADLINE_EXCEEDED)"),
      Setting("limits", "max_jpeg_scans", &l->max_jpeg_scans)
          .Range(1, 100000)
          .Help("scans per JPEG (progressive ones have ~10): a decoding-time budget"),
      Setting("limits", "max_map_bytes", &l->max_map_bytes)
          .Range(1024, 1e15)
          .Unit("bytes")
          .Help("largest map file read; larger ones are logged and skipped unread"),
      Setting("limits", "max_in_flight_per_client", &l->max_in_flight_per_client)
          .Range(1, 1000000)
          .Help("requests one connection may have queued or running (then OVERLOADED)"),
      Setting("limits", "max_in_flight_per_key", &l->max_in_flight_per_key)
          .Range(1, 1000000)
          .Help("with auth: the same over all connections of one key"),
      Setting("limits", "max_queued_bytes", &l->max_queued_bytes)
          .Range(1024, 1e15)
          .Unit("bytes")
          .Help("of requests queued or running, all clients (then OVERLOADED)"),
      Setting("limits", "max_decode_bytes", &l->max_decode_bytes)
          .Range(1 << 20, 1e15)
          .Unit("bytes")
          .Help("memory of the JPEG decodes running at once (estimated from headers)"),
      Setting("limits", "max_queue_wait_ms", &l->max_queue_wait_ms)
          .Range(1, 3600000)
          .Unit("ms")
          .Help("longest estimated wait for a worker; beyond it OVERLOADED at once"),
  };
}

// The auth: section.
SettingTable AuthSettings(AuthOptions* a) {
  return {
      Setting("auth", "enabled", &a->enabled)
          .Help("CURVE encryption; only keys listed in auth.clients connect")
          .Flag("auth"),
      Setting("auth", "server_key", &a->server_key)
          .Help("the server's key pair file (sceneloc keygen server)")
          .Flag("server-key"),
      Setting("auth", "clients", &a->clients)
          .Help("authorised client keys file, re-read on SIGHUP; admin: true may reload and "
                "read kept frames")
          .Flag("auth-clients"),
  };
}

// Every settable field of the server, each declared once: its own sections, the sessions'
// (server/session_store.cc) and the kept frames' (server/frame_keeper.cc), then the engine's
// matching: and sequence: (configs/match.yaml).
SettingTable Fields(ServerOptions* o) {
  SettingTable table = ServerSection(o);
  for (SettingTable part :
       {LimitsSettings(&o->limits), AuthSettings(&o->auth), SessionSettings(&o->sessions),
        KeepFramesSettings(&o->keep_frames), MatchSettings(&o->matching)}) {
    table.insert(table.end(), part.begin(), part.end());
  }
  return table;
}

}  // namespace

Status RequestLimits::Validate() const {
  RequestLimits copy = *this;
  SCENELOC_RETURN_IF_ERROR(CheckSettings(LimitsSettings(&copy)));
  if (max_queued_bytes < max_message_bytes) {
    return InvalidArgument("max_queued_bytes (" + std::to_string(max_queued_bytes) +
                           ") must be >= max_message_bytes (" + std::to_string(max_message_bytes) +
                           "), or the largest request could never be queued");
  }
  return Status::Ok();
}

Status AuthOptions::Validate() const {
  AuthOptions copy = *this;
  SCENELOC_RETURN_IF_ERROR(CheckSettings(AuthSettings(&copy)));
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
  ServerOptions copy = *this;
  SCENELOC_RETURN_IF_ERROR(CheckSettings(ServerSection(&copy)));
  SCENELOC_RETURN_IF_ERROR(sessions.Validate());
  SCENELOC_RETURN_IF_ERROR(keep_frames.Validate());
  SCENELOC_RETURN_IF_ERROR(limits.Validate());
  SCENELOC_RETURN_IF_ERROR(auth.Validate());
  if (!metrics_endpoint.empty()) {
    const Status address = ValidateHttpAddress(metrics_endpoint);
    if (!address.ok()) return InvalidArgument("server.metrics_endpoint: " + address.message());
  }
  if (!connect.empty() && auth.enabled) {
    return InvalidArgument(
        "server.connect (worker mode) cannot be combined with auth.enabled: clients "
        "authenticate with the server they connect to, which is then the broker (give "
        "sceneloc-broker --server-key and --clients)");
  }
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
    const std::string accepts = f.is_number() || !f.choices.empty() ? f.Describe() : "";
    flags.push_back(
        {f.FlagName(), f.section, f.key, accepts.empty() ? f.help : f.help + " (" + accepts + ")"});
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

std::string DocumentedServerSettings(const ServerOptions& options) {
  ServerOptions copy = options;
  return SettingsToDocumentedYaml(
      Fields(&copy),
      "# sceneloc-server settings, as `sceneloc-server --print-config` prints them (the\n"
      "# defaults). Every field is also a flag (sceneloc-server --help): a flag overrides the\n"
      "# file. Unknown keys are errors. Meaning of each: server/server_options.h.\n",
      {{"auth",
        "Who may connect (docs/security.md). Off: anyone who reaches\n"
        "the endpoint."},
       {"sessions", "Robots' sessions kept in the server (docs/sessions.md)."},
       {"keep_frames",
        "Frames of sessions the maps failed on, kept for the next experience\n"
        "(docs/experiences.md). Off unless dir is set."},
       {"matching", "Recognition settings, as configs/match.yaml (common/matching/localiser.h)."},
       {"sequence", "The filter of requests that name a session, as configs/match.yaml."}});
}

}  // namespace sceneloc
