// The server's replies as the wire carries them: error replies, OVERLOADED with its retry
// hint, the refusal of a newer protocol, and a reply's frames on a ZeroMQ socket. Also
// what the server reads from a request it has not parsed (its id, its kind's name).
//
// Free functions of their arguments alone; thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <zmq.hpp>

#include "proto/sceneloc.pb.h"

namespace sceneloc {

// The request kind's name in logs and metrics ("localise", "list_maps", ...; "unknown").
const char* KindName(const v1::Request& r);

// The request id of a request that cannot be parsed (too large, malformed), when its
// first field is one: generated code writes fields in number order, so a client's id
// sits at the front. 0 otherwise.
uint64_t PeekRequestId(const zmq::message_t& payload);

// The reply's bytes, stamped with the protocol this server speaks.
zmq::message_t ReplyBody(v1::Reply reply);

// Sends [identity][empty?][reply] on `socket` (the ROUTER, or a worker's PUSH).
void SendReply(zmq::socket_t& socket, zmq::message_t& identity, bool delimited,
               const v1::Reply& reply);

v1::Reply ErrorReply(uint64_t request_id, v1::StatusCode code, const std::string& error);

// UNIMPLEMENTED for a request of a newer protocol than this server speaks (nullopt when
// it speaks it); in worker mode marked retry_elsewhere, as a newer worker may be behind the
// same broker.
std::optional<v1::Reply> ProtocolRefusal(const v1::Request& request, bool worker_mode);

// Why a request is not admitted (empty: it is), and the server's estimate of when a retry
// would be, milliseconds.
struct Refusal {
  std::string why;
  double retry_after_ms = 0;
};

// An OVERLOADED reply: the refusal's reason and its retry hint, kept within [10 ms, 10 s].
v1::Reply OverloadedReply(uint64_t request_id, const Refusal& refusal);

}  // namespace sceneloc
