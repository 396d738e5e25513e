// sceneloc-server: the multi-map localisation daemon.
//   sceneloc-server [--config configs/server.yaml] [--maps DIR] [--endpoint EP]
//                   [--threads N] [any other settings field as --flag VALUE]
// Loads every *.scnl in the maps directory, serves them on a ZeroMQ ROUTER socket and
// runs until SIGTERM or SIGINT (drains in-flight requests, exits 0). SIGHUP re-reads the
// authorised clients (auth.clients, with auth.enabled) and reloads every
// map file in the directory on the map loader thread (a failure leaves that map's old
// version serving; a map whose file is gone is unloaded); with server.watch_maps the
// directory is also followed as it changes.
#include <malloc.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <map>
#include <opencv2/core/utility.hpp>

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
  const Status listed = registry->LoadDirectory(dir, &failures, &ignored);
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
    spdlog::info("map {} generation {} checksum {:08x}: {} locations, {} landmarks ({})", map->name,
                 map->generation, map->checksum, map->map.num_images(), map->map.num_landmarks(),
                 map->path);
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"sceneloc-server: serves landmark maps over ZeroMQ"};
  std::string config_path;
  app.add_option("--config", config_path, "settings file, e.g. configs/server.yaml");
  std::map<std::string, std::string> flag_values;
  for (const sceneloc::ServerFlag& flag : sceneloc::ServerFlags()) {
    app.add_option_function<std::string>(
        "--" + flag.flag,
        [&flag_values, name = flag.flag](const std::string& v) { flag_values[name] = v; },
        flag.help + " [" + flag.section + "." + flag.key + "]");
  }
  CLI11_PARSE(app, argc, argv);
  // Every allocation of 1 MiB or more (a decoded JPEG, a scoring matrix) gets its own
  // mapping and goes back to the system when freed. glibc's default threshold grows after
  // each such free (up to 32 MiB), after which big buffers come from per-thread heaps that
  // keep their pages: with 8 workers decoding 4096x4096 JPEGs in turn, peak resident
  // memory measured 420 MB against 235 MB with the threshold fixed (docs/results.md).
  mallopt(M_MMAP_THRESHOLD, 1 << 20);
  // The server spreads work over its own worker pool (server.threads); OpenCV's internal
  // threads inside SIFT would oversubscribe the cores and make --threads meaningless.
  cv::setNumThreads(1);

  sceneloc::ServerOptions options;
  const Status resolved = ResolveOptions(config_path, flag_values, &options);
  if (!resolved.ok()) {
    std::fprintf(stderr, "sceneloc-server: %s\n", resolved.message().c_str());
    return 2;
  }
  spdlog::set_level(spdlog::level::from_str(options.log_level));
  spdlog::debug("settings:\n{}", sceneloc::ServerOptionsToYaml(options));

  // Block the signals in every thread (they inherit the mask) and take them here.
  sigset_t signals;
  sigemptyset(&signals);
  for (const int s : {SIGTERM, SIGINT, SIGHUP}) sigaddset(&signals, s);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  sceneloc::MapRegistry::Options registry_options;
  registry_options.self_test = options.matching;
  registry_options.load.max_file_bytes = static_cast<uint64_t>(options.limits.max_map_bytes);
  sceneloc::MapRegistry registry(registry_options);
  if (!LoadAll(&registry, options.maps_dir)) return 2;

  auto server = sceneloc::Server::Start(options, &registry);
  if (!server.ok()) {
    spdlog::critical("{}", server.status().message());
    return 1;
  }
  for (;;) {
    int signal = 0;
    if (sigwait(&signals, &signal) != 0) continue;
    if (signal == SIGHUP) {
      spdlog::info("SIGHUP: reloading the maps in {}{}", options.maps_dir,
                   options.auth.enabled ? " and the authorised clients" : "");
      (*server)->ReloadAll();
      continue;
    }
    spdlog::info("{}: stopping", signal == SIGTERM ? "SIGTERM" : "SIGINT");
    break;
  }
  (*server)->Shutdown();
  spdlog::info("stopped");
  return 0;
}
