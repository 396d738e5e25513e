#include "server/replies.h"

#include <algorithm>
#include <cmath>

#include "proto/wire.h"

namespace sceneloc {

const char* KindName(const v1::Request& r) {
  switch (r.kind_case()) {
    case v1::Request::kLocalise:
      return "localise";
    case v1::Request::kListMaps:
      return "list_maps";
    case v1::Request::kReloadMap:
      return "reload_map";
    case v1::Request::kStats:
      return "stats";
    case v1::Request::kKeptFrames:
      return "kept_frames";
    case v1::Request::KIND_NOT_SET:
      break;
  }
  return "unknown";
}

uint64_t PeekRequestId(const zmq::message_t& payload) {
  const auto* p = static_cast<const uint8_t*>(payload.data());
  const size_t n = payload.size();
  if (n < 2 || p[0] != 0x08) return 0;  // field 1, varint
  uint64_t id = 0;
  for (size_t i = 1; i < n && i <= 10; ++i) {
    id |= static_cast<uint64_t>(p[i] & 0x7F) << (7 * (i - 1));
    if ((p[i] & 0x80) == 0) return id;
  }
  return 0;
}

zmq::message_t ReplyBody(v1::Reply reply) {
  reply.set_protocol(kProtocolVersion);
  zmq::message_t body(reply.ByteSizeLong());
  reply.SerializeToArray(body.data(), static_cast<int>(body.size()));
  return body;
}

void SendReply(zmq::socket_t& socket, zmq::message_t& identity, bool delimited,
               const v1::Reply& reply) {
  socket.send(identity, zmq::send_flags::sndmore);
  if (delimited) socket.send(zmq::message_t(), zmq::send_flags::sndmore);
  zmq::message_t body = ReplyBody(reply);
  socket.send(body, zmq::send_flags::none);
}

v1::Reply ErrorReply(uint64_t request_id, v1::StatusCode code, const std::string& error) {
  v1::Reply reply;
  reply.set_request_id(request_id);
  reply.set_status(code);
  reply.set_error(error);
  return reply;
}

std::optional<v1::Reply> ProtocolRefusal(const v1::Request& request, bool worker_mode) {
  if (request.protocol() <= kProtocolVersion) return std::nullopt;
  v1::Reply reply =
      ErrorReply(request.request_id(), v1::UNIMPLEMENTED,
                 "the request speaks sceneloc protocol " + std::to_string(request.protocol()) +
                     "; this server speaks " + std::to_string(kProtocolVersion) +
                     " (upgrade the server, or use a client of its version)");
  reply.set_retry_elsewhere(worker_mode);
  return reply;
}

v1::Reply OverloadedReply(uint64_t request_id, const Refusal& refusal) {
  v1::Reply reply = ErrorReply(request_id, v1::OVERLOADED,
                               "server is overloaded: " + refusal.why + "; retry later");
  reply.set_retry_after_ms(
      static_cast<uint32_t>(std::clamp(std::ceil(refusal.retry_after_ms), 10.0, 10000.0)));
  return reply;
}

}  // namespace sceneloc
