// `sceneloc bench`: the load generator (client/load_generator.h) as a command. Reads the
// images of a folder once (and, with --features, extracts their feature sets once, with
// the map's extractor settings), runs the load, prints a summary and optionally writes it
// as JSON:
//   {"requests": n, "ok": n, "throughput_rps": x, "elapsed_s": x, "clients": n,
//    "duration_s": x, "mode": "jpeg"|"features",
//    "latency_ms": {"p50": t, "p90": t, "p99": t, "max": t},      // successful requests
//    "server_ms": {"p50": t, "p90": t, "p99": t, "max": t},       // inside the server
//    "outside_ms": {...},  // per request, latency less server time: network, broker, client
//    "errors": {"KIND": n}, "sessions": bool, "session_localised": n,
//    "map_versions": [generation, ...],
//    "map_checksums": {"generation": "crc32 hex"}}
#pragma once

#include <string>

namespace sceneloc {

struct BenchArgs {
  std::string endpoint;
  std::string map;
  std::string image_dir;
  int clients = 1;
  double duration_s = 10;
  int timeout_ms = 10000;
  int retries = 0;  // LoadOptions::retries
  int top_k = 0;
  bool features = false;
  bool uint8 = true;      // with features: descriptors sent as uint8 (else float32)
  bool sessions = false;  // one session per client thread (LoadOptions::sessions)
  // Extractor settings for --features (client_extractor.h), as `sceneloc extract` takes
  // them: the map file's own settings and frame, else the training settings file (config)
  // with working_size over it when > 0, else the defaults.
  std::string map_file;
  std::string config;
  int working_size = 0;
  std::string json_out;  // empty: no JSON file
  std::string key_file;  // CURVE: this client's key pair and the server's public key
  std::string server_key_file;
};

// Runs the benchmark; returns the exit status: 0 when every request was answered OK,
// 1 when any failed, 2 for bad arguments or unreadable inputs.
int RunBench(const BenchArgs& args);

}  // namespace sceneloc
