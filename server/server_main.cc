// sceneloc-server: the multi-map localisation daemon.
//   sceneloc-server [--config configs/server.yaml] [--maps DIR] [--endpoint EP]
//                   [--threads N] [any other settings field as --flag VALUE]
// Loads every *.scnl in the maps directory, serves them on a ZeroMQ ROUTER socket and
// runs until SIGTERM or SIGINT (drains in-flight requests, exits 0). SIGHUP re-reads the
// authorised clients (auth.clients, with auth.enabled) and reloads every
// map file in the directory on the map loader thread (a failure leaves that map's old
// version serving; a map whose file is gone is unloaded); with server.watch_maps the
// directory is also followed as it changes.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <map>

#include "common/features/opencv_threads.h"
#include "common/util/malloc_policy.h"
#include "common/util/thread_pool.h"
#include "common/util/timer.h"
#include "common/util/version.h"
#include "server/map_registry.h"
#include "server/server.h"
#include "server/server_options.h"

namespace {

using sceneloc::Status;

// Settings from the file, then the flags given on the command line over them.
Status ResolveOptions(const std::string& config_path,
                      const std::map<std::string, std::string>& flag_values,
                      sceneloc::ServerOptions* options) {
  if (!config_path.empty()) {
    SCENELOC_RETURN_IF_ERROR(sceneloc::LoadServerOptions(config_path, options));
  }
  std::vector<std::pair<sceneloc::ServerFlag, std::string>> given;
  for (const sceneloc::ServerFlag& flag : sceneloc::ServerFlags()) {
    const auto it = flag_values.find(flag.flag);
    if (it != flag_values.end()) given.emplace_back(flag, it->second);
  }
  return sceneloc::ApplyServerFlags(given, options);
}

// Loads (or reloads) every map file in `dir`; false when `dir` cannot be listed.
bool LoadAll(sceneloc::MapRegistry* registry, const std::string& dir) {
  std::vector<Status> failures;
  std::vector<std::string> ignored;
  const sceneloc::Stopwatch watch;
  const Status listed = registry->LoadDirectory(dir, &failures, &ignored);
  const double ms = watch.Milliseconds();
  if (!listed.ok()) {
    spdlog::error("{}", listed.message());
    return false;
  }
  for (const Status& failure : failures) spdlog::error("map not loaded: {}", failure.ToString());
  if (!ignored.empty()) {
    std::string names;
    for (size_t i = 0; i < ignored.size() && i < 10; ++i) names += (i ? ", " : "") + ignored[i];
    if (ignored.size() > 10) names += ", ...";
    spdlog::warn("{}: {} entr{} not served (map files end in .scnl): {}", dir, ignored.size(),
                 ignored.size() == 1 ? "y" : "ies", names);
  }
  for (const auto& map : registry->List()) {
    spdlog::info(
        "map {} generation {} checksum {:08x}: {} locations, {} landmarks, {:.1f} MB in "
        "memory ({})",
        map->name, map->generation, map->checksum, map->map.num_places(), map->map.num_landmarks(),
        map->map.MemoryBytes() / 1e6, map->path);
  }
  spdlog::info("{} map(s) loaded from {} after {:.0f} ms", registry->List().size(), dir, ms);
  return true;
}

// Blocks SIGTERM, SIGINT and SIGHUP in this thread and every thread started after (they
// inherit the mask), so that only WaitForStop takes them; returns them.
sigset_t BlockServerSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  for (const int s : {SIGTERM, SIGINT, SIGHUP}) sigaddset(&signals, s);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  return signals;
}

// Takes the blocked `signals` until SIGTERM or SIGINT; each SIGHUP reloads.
void WaitForStop(const sigset_t& signals, const sceneloc::ServerOptions& options,
                 sceneloc::Server* server) {
  for (;;) {
    int signal = 0;
    if (sigwait(&signals, &signal) != 0) continue;
    if (signal == SIGHUP) {
      spdlog::info("SIGHUP: reloading the maps in {}{}", options.maps_dir,
                   options.auth.enabled ? " and the authorised clients" : "");
      server->ReloadAll();
      continue;
    }
    spdlog::info("{}: stopping", signal == SIGTERM ? "SIGTERM" : "SIGINT");
    return;
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"sceneloc-server: serves landmark maps over ZeroMQ"};
  app.set_version_flag("--version", std::string(sceneloc::Version()));
  std::string config_path;
  app.add_option("--config", config_path, "settings file, e.g. configs/server.yaml");
  bool print_config = false;
  app.add_flag("--print-config", print_config,
               "print the settings in effect (file, then flags) as a documented settings "
               "file, and exit");
  std::map<std::string, std::string> flag_values;
  for (const sceneloc::ServerFlag& flag : sceneloc::ServerFlags()) {
    app.add_option_function<std::string>(
        "--" + flag.flag,
        [&flag_values, name = flag.flag](const std::string& v) { flag_values[name] = v; },
        flag.help + " [" + flag.section + "." + flag.key + "]");
  }
  CLI11_PARSE(app, argc, argv);
  // Per-request buffers (SIFT's pyramid, scoring blocks) are reused from the heap, and
  // only allocations of 32 MiB or more are mapped and given back (malloc_policy.h). Mapping
  // every buffer of 1 MiB or more instead (which keeps 8 workers decoding 4096x4096 JPEGs
  // at 235 MB resident rather than 420 MB) makes each request fault in its pages afresh
  // (plain SIFT 75-110 ms instead of 20 on the 2-core VM); and a JPEG is decoded at the
  // reduced size that covers the map's frame (1/8 of a 4096x4096 one), so those big
  // buffers do not arise. docs/results.md has both measurements.
  sceneloc::UseServingMallocPolicy();
  // Until the engine pool exists, OpenCV runs its loops on the caller: its own threads
  // (TBB) beside the server's workers would oversubscribe the cores.
  sceneloc::OpenCvSerial();

  sceneloc::ServerOptions options;
  const Status resolved = ResolveOptions(config_path, flag_values, &options);
  if (!resolved.ok()) {
    std::fprintf(stderr, "sceneloc-server: %s\n", resolved.message().c_str());
    return 2;
  }
  if (print_config) {
    std::fputs(sceneloc::DocumentedServerSettings(options).c_str(), stdout);
    return 0;
  }
  spdlog::set_level(spdlog::level::from_str(options.log_level));
  spdlog::info("sceneloc-server {}", sceneloc::Version());
  spdlog::debug("settings:\n{}", sceneloc::ServerOptionsToYaml(options));

  // Block the signals in every thread (they inherit the mask) and take them here.
  const sigset_t signals = BlockServerSignals();

  sceneloc::MapRegistry::Options registry_options;
  registry_options.self_test = options.matching;
  registry_options.load.max_file_bytes = static_cast<uint64_t>(options.limits.max_map_bytes);
  sceneloc::MapRegistry registry(registry_options);
  if (!LoadAll(&registry, options.maps_dir)) return 2;

  // One request's scoring and its extraction's OpenCV loops spread over this pool while
  // its threads are idle, and stay on the request's worker under load (opencv_threads.h).
  sceneloc::ThreadPool engine_pool(options.threads);
  sceneloc::OpenCvOnThreadPool opencv_threads(&engine_pool);
  auto server = sceneloc::Server::Start(options, &registry, &engine_pool);
  if (!server.ok()) {
    spdlog::critical("{}", server.status().message());
    return 1;
  }
  WaitForStop(signals, options, server->get());
  (*server)->Shutdown();
  spdlog::info("stopped");
  return 0;
}
