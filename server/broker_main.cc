// sceneloc-broker: one address for many sceneloc-server workers (server/broker.h).
//   sceneloc-broker [--frontend tcp://*:5555] [--backend tcp://*:5556]
//                   [--server-key server.key --clients clients.yaml]
// Clients connect to the frontend as they would to a server; workers run
// `sceneloc-server --connect tcp://BROKER-HOST:5556` and may come and go. With a server key
// and a clients file, clients authenticate here (CURVE), as with a server's auth: section.
// Runs until SIGTERM or SIGINT (exits 0); SIGHUP re-reads the clients file. Exits 1 when an
// endpoint cannot be bound or a key file read, 2 for bad arguments.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <csignal>

#include "common/util/version.h"
#include "server/broker.h"

int main(int argc, char** argv) {
  CLI::App app{"sceneloc-broker: one address for many sceneloc-server workers"};
  app.set_version_flag("--version", std::string(sceneloc::Version()));
  sceneloc::BrokerOptions options;
  std::string log_level = "info";
  app.add_option("--frontend", options.frontend, "endpoint clients connect to")
      ->capture_default_str();
  app.add_option("--backend", options.backend,
                 "endpoint workers connect to (sceneloc-server --connect)")
      ->capture_default_str();
  app.add_option("--max-message-bytes", options.max_message_bytes,
                 "largest message read from a client; larger ones disconnect it")
      ->capture_default_str();
  app.add_option("--server-key", options.auth.server_key,
                 "CURVE: the broker's key pair (sceneloc keygen NAME writes NAME.key); with "
                 "--clients, only the keys listed there connect");
  app.add_option("--clients", options.auth.clients,
                 "CURVE: the authorised-clients file (the format of a server's auth.clients); "
                 "re-read on SIGHUP");
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, critical, off")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::from_str(log_level));
  if (options.auth.server_key.empty() != options.auth.clients.empty()) {
    spdlog::error("--server-key and --clients go together (CURVE needs both)");
    return 2;
  }
  options.auth.enabled = !options.auth.server_key.empty();

  // SIGTERM and SIGINT are taken by sigwait below, on this thread only: block them before
  // any other thread exists, so every thread inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  auto broker = sceneloc::Broker::Start(options);
  if (!broker.ok()) {
    spdlog::error("{}", broker.status().ToString());
    return broker.status().code() == sceneloc::StatusCode::kInvalidArgument ? 2 : 1;
  }
  spdlog::info("broker: clients on {}{}, workers on {}", (*broker)->frontend(),
               options.auth.enabled ? " (CURVE, clients in " + options.auth.clients + ")" : "",
               (*broker)->backend());
  int signal = 0;
  while (sigwait(&signals, &signal) == 0 && signal == SIGHUP) {
    const sceneloc::Status reloaded = (*broker)->ReloadClients();
    if (reloaded.ok()) {
      spdlog::info("broker: SIGHUP: re-read {}", options.auth.clients);
    } else {
      spdlog::warn("broker: SIGHUP: {} (nothing changed)", reloaded.ToString());
    }
  }
  spdlog::info("broker: {} received, stopping", signal == SIGTERM ? "SIGTERM" : "SIGINT");
  (*broker)->Stop();
  return 0;
}
