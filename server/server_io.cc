// The I/O thread: the poll loop over the ROUTER (or, in worker mode, the DEALER to the
// broker), the workers' replies and the control socket, and the delivery of replies.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstring>

#include "server/zmq_server.h"

namespace sceneloc {
namespace {

// The I/O thread wakes at least this often, so the liveness probe sees it turn.
constexpr std::chrono::milliseconds kMaxPollWait{1000};
// Worker mode: how often a missing broker is logged.
constexpr std::chrono::seconds kBrokerWarningInterval{10};

}  // namespace

void ZmqServer::IoLoop() {
  std::optional<Clock::time_point> drain_deadline;
  Clock::time_point next_summary = Clock::now() + SummaryInterval();
  for (;;) {
    if (drain_deadline && (outstanding_ == 0 || Clock::now() >= *drain_deadline)) break;
    std::vector<zmq::pollitem_t> items = {{frontend_.handle(), 0, ZMQ_POLLIN, 0},
                                          {replies_.handle(), 0, ZMQ_POLLIN, 0},
                                          {control_.handle(), 0, ZMQ_POLLIN, 0}};
    if (!options_.connect.empty()) items.push_back({monitor_.handle(), 0, ZMQ_POLLIN, 0});
    try {
      zmq::poll(items, PollTimeout(drain_deadline, next_summary));
      io_woke_.store(Clock::now().time_since_epoch().count(), std::memory_order_relaxed);
      if (items.size() > 3 && (items[3].revents & ZMQ_POLLIN)) ReadMonitorEvent();
      if (items[1].revents & ZMQ_POLLIN) ForwardReply();
      if (items[0].revents & ZMQ_POLLIN) ReadRequest(drain_deadline.has_value());
      if (items[2].revents & ZMQ_POLLIN) {
        zmq::message_t ignored;
        (void)control_.recv(ignored);
        drain_deadline =
            Clock::now() + std::chrono::duration_cast<Clock::duration>(
                               std::chrono::duration<double>(options_.drain_timeout_s));
        draining_ = true;
        spdlog::info("shutting down: draining {} request(s) in flight", outstanding_);
      }
    } catch (const zmq::error_t& e) {
      // Nothing a peer sends should get here; keep serving, but say so.
      spdlog::error("I/O thread: ZeroMQ error: {}", e.what());
      stats_.RecordReply("INTERNAL", false, 0);
    }
    WarnIfNoBroker();
    if (options_.summary_interval_s > 0 && Clock::now() >= next_summary) {
      LogSummary();
      next_summary = Clock::now() + SummaryInterval();
    }
  }
  FinishDrain();
}

ZmqServer::Clock::duration ZmqServer::SummaryInterval() const {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
      options_.summary_interval_s > 0 ? options_.summary_interval_s : 3600.0));
}

std::chrono::milliseconds ZmqServer::PollTimeout(const std::optional<Clock::time_point>& deadline,
                                                 Clock::time_point next_summary) const {
  Clock::time_point wake = next_summary;
  if (deadline && *deadline < wake) wake = *deadline;
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(wake - Clock::now());
  return std::min(std::max(ms, std::chrono::milliseconds(0)) + std::chrono::milliseconds(1),
                  kMaxPollWait);
}

ZmqServer::Incoming ZmqServer::ReceiveFrames() {
  Incoming in;
  std::vector<zmq::message_t> frames;
  bool more = true;
  while (more) {
    zmq::message_t frame;
    if (!frontend_.recv(frame, zmq::recv_flags::dontwait)) break;
    more = frame.more();
    ++in.frames;
    in.bytes += frame.size();
    if (frames.size() < kMaxFrames) frames.push_back(std::move(frame));
  }
  if (!frames.empty()) in.identity = std::move(frames[0]);
  if (frames.size() == 3 && frames[1].size() == 0) {
    in.delimited = true;
    in.payload = std::move(frames[2]);
  } else if (frames.size() == 2) {
    in.payload = std::move(frames[1]);
  }
  return in;
}

void ZmqServer::ForwardReply() {
  std::vector<zmq::message_t> frames;
  bool more = true;
  while (more) {
    zmq::message_t frame;
    if (!replies_.recv(frame, zmq::recv_flags::dontwait)) return;
    more = frame.more();
    frames.push_back(std::move(frame));
  }
  Released(ConnectionKey(frames.front()));  // the identity frame
  Deliver(frames);
  --outstanding_;
}

void ZmqServer::ToClient(zmq::message_t& identity, bool delimited, const v1::Reply& reply) {
  std::vector<zmq::message_t> frames;
  frames.push_back(std::move(identity));
  if (delimited) frames.emplace_back();
  frames.push_back(ReplyBody(reply));
  Deliver(frames);
}

void ZmqServer::Deliver(std::vector<zmq::message_t>& frames) {
  const char* why = nullptr;
  try {
    for (size_t i = 0; i < frames.size(); ++i) {
      const bool last = i + 1 == frames.size();
      const auto flags =
          zmq::send_flags::dontwait | (last ? zmq::send_flags::none : zmq::send_flags::sndmore);
      if (!frontend_.send(frames[i], flags)) {
        why = "its connection has the most unread replies ZeroMQ holds (it stopped reading)";
        break;
      }
    }
  } catch (const zmq::error_t& e) {
    if (e.num() != EHOSTUNREACH) throw;
    why = "the client has gone";
  }
  if (why == nullptr) return;
  stats_.RecordUndelivered();
  metrics_.RecordUndelivered();
  ++undelivered_since_log_;
  const Clock::time_point now = Clock::now();
  if (now - last_undelivered_log_ >= std::chrono::seconds(1)) {
    spdlog::warn("a reply was not delivered: {} ({} undelivered since the last such line)", why,
                 undelivered_since_log_);
    last_undelivered_log_ = now;
    undelivered_since_log_ = 0;
  }
}

void ZmqServer::ReadMonitorEvent() {
  zmq::message_t event, address;
  if (!monitor_.recv(event, zmq::recv_flags::dontwait)) return;
  if (event.more()) (void)monitor_.recv(address, zmq::recv_flags::dontwait);
  if (event.size() < sizeof(uint16_t)) return;
  uint16_t id = 0;
  std::memcpy(&id, event.data(), sizeof(id));
  if (id == ZMQ_EVENT_CONNECTED) {
    spdlog::info("connected to the broker at {}", options_.connect);
    broker_connected_ = true;
  } else if (id == ZMQ_EVENT_DISCONNECTED) {
    spdlog::warn("lost the broker at {}; reconnecting", options_.connect);
    broker_connected_ = false;
    last_broker_warning_ = Clock::now();
  }
}

void ZmqServer::WarnIfNoBroker() {
  if (options_.connect.empty() || broker_connected_) return;
  const Clock::time_point now = Clock::now();
  if (now - last_broker_warning_ < kBrokerWarningInterval) return;
  if (last_broker_warning_ != Clock::time_point{}) {
    spdlog::warn("no broker at {} yet; still trying (is sceneloc-broker running there?)",
                 options_.connect);
  }
  last_broker_warning_ = now;
}

}  // namespace sceneloc
