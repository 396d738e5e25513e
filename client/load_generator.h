// The load generator behind `sceneloc bench`: N client threads, each with its own
// sceneloc::Client, send localise requests back to back for a fixed time and record what
// came back (latency, status, the map version that answered).
//
// The queries are prepared once before the clock starts (JPEG bytes, or feature sets
// already encoded as requests), so the timed section of a request is the client's call
// alone: serialising, the network, the server, parsing the reply.
//
// Thread-safe: RunLoad may be called from any thread; it owns the threads it starts.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "common/features/feature_set.h"
#include "common/util/status.h"
#include "proto/sceneloc.pb.h"
#include "proto/wire.h"

namespace sceneloc {

struct LoadOptions {
  // Server endpoint, e.g. tcp://127.0.0.1:5555.
  std::string endpoint;
  // Map every request asks for.
  std::string map;
  // Client threads, each with its own connection (>= 1).
  int clients = 1;
  // Seconds during which new requests are started (> 0). A request in flight at the end
  // is waited for, at most timeout_ms.
  double duration_s = 10;
  // Per-request timeout, milliseconds (>= 1). A request is not retried: a timeout is
  // counted as the error NO_REPLY, so retries cannot hide failures. After an OVERLOADED
  // reply a client thread backs off (10 ms, doubling to 320 ms) before its next request.
  int timeout_ms = 10000;
  // Attempts after a timeout, UNAVAILABLE or retry_elsewhere reply, each on a fresh socket
  // (ClientOptions::retries). 0 (the default): none, so retries cannot hide failures; a
  // fleet benchmark that kills a worker sets it to count what the client's retry saves.
  int retries = 0;
  // Ranked locations asked for (0 = the server's default).
  int top_k = 0;
  // Each client thread is one robot's session (named "<session_prefix>-<thread>", reset on
  // its first request) going through the queries in order from its starting point.
  bool sessions = false;
  std::string session_prefix = "bench";
  // CURVE key files (ClientOptions::key_file, server_key_file); empty: no CURVE.
  std::string key_file;
  std::string server_key_file;

  Status Validate() const;
};

// One query, ready to send: a localise request built once (its map and top_k are set by
// RunLoad).
struct LoadQuery {
  std::string name;  // file name, for messages
  v1::Request request;
};
// A query carrying the whole JPEG file.
LoadQuery JpegQuery(std::string name, std::string jpeg);
// A query carrying a feature set extracted on the client, its descriptors as `encoding`
// (float32: 1 KB per keypoint for both descriptors; uint8: a quarter of it).
LoadQuery FeatureQuery(std::string name, const FeatureSet& features,
                       DescriptorEncoding encoding = DescriptorEncoding::kFloat32);

struct LoadResult {
  int64_t requests = 0;  // completed requests, answered or not
  int64_t ok = 0;        // with status OK
  double elapsed_s = 0;  // from the first request started to the last one finished
  // Per successful request, milliseconds, in completion order per client (unsorted).
  std::vector<double> latency_ms;
  // Server-side total_ms (received by the server to reply built) of successful requests.
  std::vector<double> server_ms;
  // Per successful request, its latency less its server_ms: the time spent outside the
  // server (the client's serialising, the network or a broker, both ends' ZeroMQ threads).
  // Paired per request, so the server's own run-to-run drift does not enter it, as it does
  // a difference of the two medians.
  std::vector<double> outside_ms;
  // The server's stage times of successful requests (Timings: queue, decode, extract,
  // descriptor, neighbourhood, likelihood, holistic, verify), by stage name, unsorted.
  std::map<std::string, std::vector<double>> stage_ms;
  // Failed requests by kind: the reply's status name (NOT_FOUND, OVERLOADED, ...), or
  // NO_REPLY (timed out / no connection) and BAD_REPLY (unparsable or wrong kind).
  std::map<std::string, int64_t> errors;
  // With sessions: successful replies whose session answer was LOCALISED.
  int64_t session_localised = 0;
  // Attempts the clients sent again (LoadOptions::retries; Client::retries()).
  int64_t retries = 0;
  // Map generations (and the checksum of each) seen in successful replies.
  std::map<uint64_t, uint32_t> map_versions;

  double ThroughputRps() const { return elapsed_s > 0 ? requests / elapsed_s : 0; }
};

// Runs the load: client i starts at query i * size / clients and cycles through `queries`.
// Errors: invalid options, no queries, or a client that cannot be created.
StatusOr<LoadResult> RunLoad(const LoadOptions& options, const std::vector<LoadQuery>& queries);

// The q-quantile (0..1) of `values` by nearest rank; 0 for no values.
double Quantile(std::vector<double> values, double q);

}  // namespace sceneloc
