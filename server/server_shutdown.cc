// Shutdown: the drain (requests in flight answered, those still queued at the deadline
// refused UNAVAILABLE), then every thread joined and the sockets closed.
#include <spdlog/spdlog.h>

#include "server/zmq_server.h"

namespace sceneloc {

void ZmqServer::Shutdown() {
  MutexLock lock(&shutdown_mutex_);
  if (!io_thread_.joinable()) return;
  draining_ = true;  // readiness fails from now on; liveness holds until the end
  try {
    zmq::socket_t stop(context_, zmq::socket_type::push);
    stop.set(zmq::sockopt::linger, -1);
    stop.connect(kControlEndpoint);
    stop.send(zmq::str_buffer("stop"), zmq::send_flags::none);
  } catch (const zmq::error_t& e) {
    spdlog::error("shutdown: cannot signal the I/O thread: {}", e.what());
  }
  io_thread_.join();
  if (http_ != nullptr) http_->Stop();
}

void ZmqServer::FinishDrain() {
  for (std::unique_ptr<Job>& job : queue_.Close()) {
    // A large request is parsed by the worker that takes it: one still queued has only its
    // bytes, so its id is read from them (as Dispatch does).
    const uint64_t id = job->parsed ? job->request.request_id() : PeekRequestId(job->raw);
    const v1::Reply reply =
        ErrorReply(id, v1::UNAVAILABLE, "server shut down before this request was started");
    Record(job->parsed ? KindName(job->request) : "localise", job->parsed ? &job->request : nullptr,
           reply, job->received);
    ToClient(job->identity, job->delimited, reply);
    --outstanding_;
  }
  for (std::thread& worker : workers_) worker.join();
  loader_->Stop();  // finishes its load; queued reloads are answered UNAVAILABLE
  try {
    while (outstanding_ > 0 && replies_.handle() != nullptr) {
      zmq::pollitem_t item{replies_.handle(), 0, ZMQ_POLLIN, 0};
      if (zmq::poll(&item, 1, std::chrono::milliseconds(0)) == 0) break;
      ForwardReply();
    }
  } catch (const zmq::error_t& e) {
    spdlog::error("shutdown: {}", e.what());
  }
  LogSummary();
  frontend_.close();
  replies_.close();
  control_.close();
  monitor_.close();
  loader_push_.close();  // the loader thread has ended
  io_thread_done_ = true;
}

}  // namespace sceneloc
