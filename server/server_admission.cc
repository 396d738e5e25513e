// Admission: which requests the I/O thread queues for the workers. The limits per
// connection, per key and on queued bytes (limits.max_in_flight_per_*, max_queued_bytes),
// and the estimate of the wait a new request would have (limits.max_queue_wait_ms).
#include <algorithm>

#include "server/zmq_server.h"

namespace sceneloc {

double ZmqServer::ServiceMs() const {
  const double ms = service_ms_.load(std::memory_order_relaxed);
  return ms > 0 ? ms : 100.0;
}

namespace {

// The requests waiting ahead of a new one: every one for a large request, the small ones
// for a small request (it is taken ahead of the large ones).
template <typename Queue>
size_t Ahead(const Queue& queue, bool large) {
  return large ? queue.size() : queue.size_of(false);
}

}  // namespace

double ZmqServer::QueuedWorkMs(bool large) const {
  const size_t ahead = Ahead(queue_, large);
  const int workers =
      large ? options_.threads : std::max(1, options_.threads - queue_.large_held());
  return static_cast<double>(ahead) * service_ms_.load(std::memory_order_relaxed) / workers;
}

Refusal ZmqServer::WaitRefusal(bool large) const {
  // The requests waiting ahead of this one; those already running are not counted (an
  // idle server admits anything, however slow).
  const double wait_ms = QueuedWorkMs(large);
  const int limit = options_.limits.max_queue_wait_ms;
  if (wait_ms <= limit) return {};
  return {"about " + std::to_string(static_cast<int>(wait_ms)) + " ms of work (" +
              std::to_string(Ahead(queue_, large)) + " requests of ~" +
              std::to_string(static_cast<int>(ServiceMs())) +
              " ms) is queued ahead of this request; limits.max_queue_wait_ms is " +
              std::to_string(limit),
          wait_ms - limit + ServiceMs() / options_.threads};
}

std::string ZmqServer::ConnectionKey(const zmq::message_t& identity) {
  return std::string(identity.data<char>(), identity.size());
}

Refusal ZmqServer::AdmissionRefusal(const std::string& connection, const std::string& client,
                                    size_t bytes, bool large) const {
  const auto it = in_flight_.find(connection);
  const int mine = it == in_flight_.end() ? 0 : it->second.count;
  if (mine >= options_.limits.max_in_flight_per_client) {
    return {"this connection already has " + std::to_string(mine) +
                " requests queued or running, the most one connection may have "
                "(limits.max_in_flight_per_client)",
            ServiceMs()};
  }
  if (!client.empty()) {
    const auto k = key_in_flight_.find(client);
    const int keyed = k == key_in_flight_.end() ? 0 : k->second;
    if (keyed >= options_.limits.max_in_flight_per_key) {
      return {"the connections of key '" + client + "' already have " + std::to_string(keyed) +
                  " requests queued or running, the most one key may have "
                  "(limits.max_in_flight_per_key)",
              ServiceMs()};
    }
  }
  const int64_t held = queued_bytes_;
  if (large && held + static_cast<int64_t>(bytes) > options_.limits.max_queued_bytes) {
    return {"requests queued or running hold " + std::to_string(held) + " bytes; this one (" +
                std::to_string(bytes) + " bytes) would pass limits.max_queued_bytes (" +
                std::to_string(options_.limits.max_queued_bytes) + ")",
            ServiceMs()};
  }
  return {};
}

void ZmqServer::Track(const std::string& connection, const std::string& client) {
  InFlight& entry = in_flight_[connection];
  ++entry.count;
  entry.client = client;
  if (!client.empty()) ++key_in_flight_[client];
}

void ZmqServer::Released(const std::string& connection) {
  const auto it = in_flight_.find(connection);
  if (it == in_flight_.end()) return;
  if (!it->second.client.empty()) {
    const auto k = key_in_flight_.find(it->second.client);
    if (k != key_in_flight_.end() && --k->second <= 0) key_in_flight_.erase(k);
  }
  if (--it->second.count <= 0) in_flight_.erase(it);
}

// Folds one request's worker time into the running mean the admission estimate uses:
// what the request would take with every worker busy. One that ran beside idle workers
// had their threads' help (a lone JPEG request: about 1.5x faster on 2 threads), which a
// queue of requests will not get; its time is scaled by threads / busy workers, so the
// estimate errs on the side of refusing (measured: without it, a burst after a quiet
// spell was admitted on the lone time and a well-behaved client was then refused
// OVERLOADED for a second; docs/results.md).
void ZmqServer::RecordServiceTime(double wall_ms, int busy_workers) {
  const double ms = wall_ms * options_.threads / std::max(1, busy_workers);
  double old = service_ms_.load(std::memory_order_relaxed);
  while (!service_ms_.compare_exchange_weak(old, old == 0 ? ms : 0.8 * old + 0.2 * ms,
                                            std::memory_order_relaxed)) {
  }
}

}  // namespace sceneloc
