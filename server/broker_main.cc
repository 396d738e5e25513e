// sceneloc-broker: one address for many sceneloc-server workers (server/broker.h).
//   sceneloc-broker [--frontend tcp://*:5555] [--backend tcp://*:5556]
// Clients connect to the frontend as they would to a server; workers run
// `sceneloc-server --connect tcp://BROKER-HOST:5556` and may come and go. Runs until SIGTERM
// or SIGINT (exits 0); exits 1 when an endpoint cannot be bound, 2 for bad arguments.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <csignal>

#include "server/broker.h"

int main(int argc, char** argv) {
  CLI::App app{"sceneloc-broker: one address for many sceneloc-server workers"};
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
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error, critical, off")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::from_str(log_level));

  // SIGTERM and SIGINT are taken by sigwait below, on this thread only: block them before
  // any other thread exists, so every thread inherits the mask.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  auto broker = sceneloc::Broker::Start(options);
  if (!broker.ok()) {
    spdlog::error("{}", broker.status().ToString());
    return broker.status().code() == sceneloc::StatusCode::kInvalidArgument ? 2 : 1;
  }
  spdlog::info("broker: clients on {}, workers on {}", (*broker)->frontend(), (*broker)->backend());
  int signal = 0;
  sigwait(&signals, &signal);
  spdlog::info("broker: {} received, stopping", signal == SIGTERM ? "SIGTERM" : "SIGINT");
  (*broker)->Stop();
  return 0;
}
