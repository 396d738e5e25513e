#include "client/load_generator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <thread>
#include <utility>

#include "client/client.h"
#include "proto/wire.h"

namespace sceneloc {
namespace {

using Clock = std::chrono::steady_clock;

// What one client thread saw; merged into the LoadResult after every thread has joined,
// so the threads share nothing while they run.
struct ClientTally {
  LoadResult result;
  Clock::time_point finished;
};

// Counts one completed call into `tally`.
void Record(const StatusOr<v1::Reply>& reply, double ms, ClientTally* tally) {
  LoadResult& r = tally->result;
  ++r.requests;
  if (!reply.ok()) {
    ++r.errors[reply.status().code() == StatusCode::kIoError ? "NO_REPLY" : "BAD_REPLY"];
    return;
  }
  if (reply->status() != v1::OK) {
    ++r.errors[v1::StatusCode_Name(reply->status())];
    return;
  }
  if (!reply->has_localise()) {
    ++r.errors["BAD_REPLY"];
    return;
  }
  ++r.ok;
  r.latency_ms.push_back(ms);
  const v1::Timings& t = reply->localise().timings();
  r.server_ms.push_back(t.total_ms());
  r.outside_ms.push_back(ms - t.total_ms());
  for (const auto& [stage, value] : {std::pair{"queue", t.queue_ms()},
                                     {"decode", t.decode_ms()},
                                     {"extract", t.extract_ms()},
                                     {"place", t.place_ms()},
                                     {"descriptor", t.descriptor_ms()},
                                     {"neighbourhood", t.neighbourhood_ms()},
                                     {"likelihood", t.likelihood_ms()},
                                     {"holistic", t.holistic_ms()},
                                     {"verify", t.verify_ms()}}) {
    r.stage_ms[stage].push_back(value);
  }
  if (reply->localise().has_session() && reply->localise().session().decision() == v1::LOCALISED) {
    ++r.session_localised;
  }
  const v1::MapVersion& version = reply->localise().map();
  r.map_versions[version.generation()] = version.checksum();
}

// One client: requests back to back, starting at `first`, until `deadline`.
// `session`: the session every request names (empty = none), reset on the first.
void RunClient(Client* client, const std::vector<v1::Request>& requests, size_t first,
               const std::string& session, Clock::time_point deadline, ClientTally* tally) {
  int overloaded_in_a_row = 0;
  bool first_request = true;
  for (size_t i = first; Clock::now() < deadline; i = (i + 1) % requests.size()) {
    v1::Request request = requests[i];  // Call takes it by value; copy before the clock
    if (!session.empty()) {
      request.mutable_localise()->set_session(session);
      request.mutable_localise()->set_reset_session(first_request);
      first_request = false;
    }
    const auto start = Clock::now();
    const StatusOr<v1::Reply> reply = client->Call(std::move(request));
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    Record(reply, ms, tally);
    // As a robot should: after OVERLOADED, back off (the server's retry_after_ms, or 10 ms
    // doubling to 320 ms from an older server) instead of asking again at once; a storm of
    // instant retries takes the CPU the workers need.
    if (reply.ok() && reply->status() == v1::OVERLOADED) {
      const int backoff_ms = reply->retry_after_ms() > 0 ? static_cast<int>(reply->retry_after_ms())
                                                         : 10 << std::min(overloaded_in_a_row, 5);
      ++overloaded_in_a_row;
      std::this_thread::sleep_for(std::chrono::milliseconds(backoff_ms));
    } else {
      overloaded_in_a_row = 0;
    }
  }
  tally->finished = Clock::now();
  tally->result.retries = client->retries();
}

void Merge(const LoadResult& from, LoadResult* into) {
  into->requests += from.requests;
  into->ok += from.ok;
  into->session_localised += from.session_localised;
  into->retries += from.retries;
  into->latency_ms.insert(into->latency_ms.end(), from.latency_ms.begin(), from.latency_ms.end());
  into->server_ms.insert(into->server_ms.end(), from.server_ms.begin(), from.server_ms.end());
  into->outside_ms.insert(into->outside_ms.end(), from.outside_ms.begin(), from.outside_ms.end());
  for (const auto& [stage, values] : from.stage_ms) {
    std::vector<double>& to = into->stage_ms[stage];
    to.insert(to.end(), values.begin(), values.end());
  }
  for (const auto& [kind, n] : from.errors) into->errors[kind] += n;
  for (const auto& [generation, checksum] : from.map_versions) {
    into->map_versions[generation] = checksum;
  }
}

}  // namespace

Status LoadOptions::Validate() const {
  if (endpoint.empty()) return InvalidArgument("no server endpoint");
  if (map.empty()) return InvalidArgument("no map name");
  if (clients < 1) return InvalidArgument("clients must be >= 1");
  if (!(duration_s > 0) || !std::isfinite(duration_s)) {
    return InvalidArgument("duration must be > 0 seconds");
  }
  if (timeout_ms < 1) return InvalidArgument("timeout_ms must be >= 1");
  if (retries < 0) return InvalidArgument("retries must be >= 0");
  if (top_k < 0) return InvalidArgument("top_k must be >= 0");
  if (sessions) SCENELOC_RETURN_IF_ERROR(CheckSessionName(session_prefix + "-0"));
  return Status::Ok();
}

LoadQuery JpegQuery(std::string name, std::string jpeg) {
  LoadQuery query{std::move(name), {}};
  query.request.mutable_localise()->set_jpeg(std::move(jpeg));
  return query;
}

LoadQuery FeatureQuery(std::string name, const FeatureSet& features, DescriptorEncoding encoding) {
  LoadQuery query{std::move(name), {}};
  EncodeFeatureSet(features, encoding, query.request.mutable_localise()->mutable_features());
  return query;
}

StatusOr<LoadResult> RunLoad(const LoadOptions& options, const std::vector<LoadQuery>& queries) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  if (queries.empty()) return InvalidArgument("no queries to send");
  std::vector<v1::Request> requests;
  for (const LoadQuery& query : queries) {
    requests.push_back(query.request);
    requests.back().mutable_localise()->set_map(options.map);
    requests.back().mutable_localise()->set_top_k(options.top_k);
  }
  ClientOptions client_options;
  client_options.timeout_ms = options.timeout_ms;
  client_options.retries = options.retries;
  client_options.overload_wait_ms = 0;  // refusals are counted; Run() backs off itself
  client_options.key_file = options.key_file;
  client_options.server_key_file = options.server_key_file;
  // Made here, used on the client threads: a ZeroMQ socket may move to another thread
  // across a full memory barrier, which starting the thread is.
  std::vector<std::unique_ptr<Client>> clients;
  for (int c = 0; c < options.clients; ++c) {
    SCENELOC_ASSIGN_OR_RETURN(auto client, Client::Connect(options.endpoint, client_options));
    clients.push_back(std::move(client));
  }

  std::vector<ClientTally> tallies(clients.size());
  const auto start = Clock::now();
  const auto deadline = start + std::chrono::duration_cast<Clock::duration>(
                                    std::chrono::duration<double>(options.duration_s));
  std::vector<std::thread> threads;
  for (size_t c = 0; c < clients.size(); ++c) {
    const size_t first = c * requests.size() / clients.size();
    const std::string session =
        options.sessions ? options.session_prefix + "-" + std::to_string(c) : std::string();
    threads.emplace_back(RunClient, clients[c].get(), std::cref(requests), first, session, deadline,
                         &tallies[c]);
  }
  LoadResult result;
  Clock::time_point finished = start;
  for (size_t c = 0; c < threads.size(); ++c) {
    threads[c].join();
    Merge(tallies[c].result, &result);
    finished = std::max(finished, tallies[c].finished);
  }
  result.elapsed_s = std::chrono::duration<double>(finished - start).count();
  return result;
}

double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  const double rank = std::ceil(std::clamp(q, 0.0, 1.0) * static_cast<double>(values.size()));
  const size_t k = std::max<size_t>(1, static_cast<size_t>(rank)) - 1;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace sceneloc
