// The worker threads: each takes a job from the queue, answers it with the RequestHandler
// and passes the reply to the I/O thread through its own PUSH socket.
#include <spdlog/spdlog.h>

#include "proto/wire.h"
#include "server/zmq_server.h"

namespace sceneloc {
namespace {

// Counts a worker as busy for its lifetime.
class BusyWorker {
 public:
  explicit BusyWorker(std::atomic<int>* count) : count_(count) {
    count_->fetch_add(1, std::memory_order_relaxed);
  }
  ~BusyWorker() { count_->fetch_sub(1, std::memory_order_relaxed); }
  BusyWorker(const BusyWorker&) = delete;
  BusyWorker& operator=(const BusyWorker&) = delete;

 private:
  std::atomic<int>* const count_;
};

// Gives a job's lane back to its queue (BoundedQueue::Done) however its work ends.
template <typename Queue>
class LaneRelease {
 public:
  LaneRelease(Queue* queue, bool large) : queue_(queue), large_(large) {}
  ~LaneRelease() { queue_->Done(large_); }
  LaneRelease(const LaneRelease&) = delete;
  LaneRelease& operator=(const LaneRelease&) = delete;

 private:
  Queue* const queue_;
  const bool large_;
};

}  // namespace

void ZmqServer::WorkerLoop() {
  zmq::socket_t push(context_, zmq::socket_type::push);
  push.set(zmq::sockopt::linger, -1);
  push.connect(kRepliesEndpoint);
  bool large = false;
  while (std::optional<std::unique_ptr<Job>> job = queue_.Pop(&large)) {
    const LaneRelease release(&queue_, large);
    Job& j = **job;
    // Handle() turns every exception into an error reply; this catches what is left
    // (the stats or the reply itself out of memory), so no worker ever ends the process.
    try {
      v1::Reply reply;
      const Clock::time_point start = Clock::now();
      if (IsStale(j, start, &reply)) {
        // answered OVERLOADED without the work
      } else if (ParseOnWorker(j, !options_.connect.empty(), &reply)) {
        BusyWorker busy(&busy_workers_);  // counted off even if Handle throws
        handler_.Handle(j.request, j.received, &reply, j.client);
        if (!options_.connect.empty()) AsWorker(j.request, &reply);
        // Workers busy at the end, this one included: fewer than all means idle pool
        // threads may have helped this request (opencv_threads.h, ThreadPool).
        RecordServiceTime(MsSince(start), busy_workers_.load(std::memory_order_relaxed));
      }
      Record(KindName(j.request), &j.request, reply, j.received);
      SendReply(push, j.identity, j.delimited, reply);
    } catch (const zmq::error_t& e) {
      spdlog::error("worker: cannot pass a reply to the I/O thread: {}", e.what());
    } catch (const std::exception& e) {
      spdlog::error("worker: request {} failed outside the handler: {}", j.request.request_id(),
                    e.what());
      try {
        SendReply(push, j.identity, j.delimited,
                  ErrorReply(j.request.request_id(), v1::INTERNAL,
                             std::string("server error: ") + e.what()));
      } catch (...) {
      }
    }
    queued_bytes_ -= static_cast<int64_t>(j.bytes);
  }
}

// Worker mode: a map this process does not serve may be served by another worker of the
// same broker (during a map roll-out the workers of a group are out of step for a
// while). The reply stays NOT_FOUND, marked retry_elsewhere: sceneloc::Client retries it
// on a fresh socket (the broker hands the retry to the next worker) and returns the
// NOT_FOUND only when every retry got one, so a map no worker serves is a clear
// NOT_FOUND within the retries, not a timeout.
void ZmqServer::AsWorker(const v1::Request& request, v1::Reply* reply) {
  if (reply->status() != v1::NOT_FOUND || !request.has_localise()) return;
  reply->set_retry_elsewhere(true);
  reply->set_error(reply->error() + " on this worker (another worker of its broker may serve it)");
}

bool ZmqServer::IsStale(const Job& j, Clock::time_point now, v1::Reply* reply) const {
  const double waited_ms = std::chrono::duration<double, std::milli>(now - j.received).count();
  if (waited_ms <= 2.0 * options_.limits.max_queue_wait_ms) return false;
  const uint64_t id = j.parsed ? j.request.request_id() : PeekRequestId(j.raw);
  *reply = OverloadedReply(
      id, {"this request waited " + std::to_string(static_cast<int>(waited_ms)) +
               " ms for a worker, more than twice limits.max_queue_wait_ms (" +
               std::to_string(options_.limits.max_queue_wait_ms) + "); it was not worked on",
           QueuedWorkMs(!j.parsed) - options_.limits.max_queue_wait_ms + ServiceMs()});
  return true;
}

bool ZmqServer::ParseOnWorker(Job& j, bool worker_mode, v1::Reply* reply) const {
  if (j.parsed) return true;
  const uint64_t peeked_id = PeekRequestId(j.raw);
  // Too many keypoints is refused before the parse, which would allocate a message for
  // each: millions of empty ones fit in a request and would hold a worker for seconds.
  if (const int64_t keypoints = CountWireKeypoints(j.raw.data(), j.raw.size());
      keypoints > options_.limits.max_keypoints) {
    j.raw.rebuild();
    j.parsed = true;
    *reply = ErrorReply(peeked_id, v1::RESOURCE_EXHAUSTED,
                        TooManyKeypoints(keypoints, options_.limits.max_keypoints).message() +
                            " (limits.max_keypoints; counted before parsing)");
    return false;
  }
  const bool ok = j.request.ParseFromArray(j.raw.data(), static_cast<int>(j.raw.size()));
  const size_t size = j.raw.size();
  j.raw.rebuild();  // the parsed request holds what is needed
  j.parsed = true;
  if (!ok) {
    *reply =
        ErrorReply(peeked_id, v1::INVALID_ARGUMENT, "request is not a valid sceneloc.v1.Request");
    return false;
  }
  if (j.request.kind_case() != v1::Request::kLocalise) {
    *reply =
        ErrorReply(j.request.request_id(), v1::INVALID_ARGUMENT,
                   std::string("a ") + KindName(j.request) + " request of " + std::to_string(size) +
                       " bytes: only localise requests may be larger than " +
                       std::to_string(kInlineParseBytes) + " bytes");
    return false;
  }
  if (auto refusal = ProtocolRefusal(j.request, worker_mode)) {
    *reply = *std::move(refusal);
    return false;
  }
  return true;
}

}  // namespace sceneloc
