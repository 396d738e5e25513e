// The server's reply builders (server/replies.h): what each puts in a reply, the request
// id read from bytes that were not parsed, and a reply's frames on a real socket.
#include "server/replies.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <iterator>
#include <limits>
#include <string>
#include <vector>
#include <zmq.hpp>
#include <zmq_addon.hpp>

#include "proto/wire.h"

namespace sceneloc {
namespace {

zmq::message_t Bytes(const std::string& bytes) {
  return zmq::message_t(bytes.data(), bytes.size());
}

// Each request kind has its name in logs and metrics; a request of no kind is "unknown".
TEST(RepliesTest, KindNames) {
  v1::Request request;
  EXPECT_STREQ(KindName(request), "unknown");
  request.mutable_localise();
  EXPECT_STREQ(KindName(request), "localise");
  request.mutable_list_maps();
  EXPECT_STREQ(KindName(request), "list_maps");
  request.mutable_reload_map();
  EXPECT_STREQ(KindName(request), "reload_map");
  request.mutable_stats();
  EXPECT_STREQ(KindName(request), "stats");
}

// The id at the front of a serialised request is read without parsing it, whatever its
// size, even when what follows is garbage; anything else reads as 0.
TEST(RepliesTest, PeekRequestIdReadsTheLeadingId) {
  for (const uint64_t id : {uint64_t{1}, uint64_t{127}, uint64_t{128}, uint64_t{300},
                            std::numeric_limits<uint64_t>::max()}) {
    v1::Request request;
    request.set_request_id(id);
    request.mutable_localise()->set_jpeg(std::string(1000, 'x'));
    EXPECT_EQ(PeekRequestId(Bytes(request.SerializeAsString())), id);
    EXPECT_EQ(PeekRequestId(Bytes(request.SerializeAsString().substr(0, 12) + "\xff\xff")), id);
  }
  v1::Request no_id;
  no_id.mutable_stats();
  EXPECT_EQ(PeekRequestId(Bytes(no_id.SerializeAsString())), 0u);  // starts with another field
  EXPECT_EQ(PeekRequestId(Bytes("")), 0u);
  EXPECT_EQ(PeekRequestId(Bytes(std::string("\x08", 1))), 0u);            // no varint
  EXPECT_EQ(PeekRequestId(Bytes(std::string("\x08\x80\x80", 3))), 0u);    // varint cut short
  EXPECT_EQ(PeekRequestId(Bytes("\x08" + std::string(11, '\xff'))), 0u);  // over 10 bytes
  EXPECT_EQ(PeekRequestId(Bytes(std::string("\x10\x05", 2))), 0u);        // field 2
}

// An error reply carries the id, the status and the message, and nothing else.
TEST(RepliesTest, ErrorReplyCarriesIdStatusAndMessage) {
  const v1::Reply reply = ErrorReply(17, v1::NOT_FOUND, "no map named 'x'");
  EXPECT_EQ(reply.request_id(), 17u);
  EXPECT_EQ(reply.status(), v1::NOT_FOUND);
  EXPECT_EQ(reply.error(), "no map named 'x'");
  EXPECT_EQ(reply.kind_case(), v1::Reply::KIND_NOT_SET);
  EXPECT_EQ(reply.retry_after_ms(), 0u);
  EXPECT_FALSE(reply.retry_elsewhere());
}

// OVERLOADED says why and asks for a retry later, with the hint rounded up and kept within
// [10 ms, 10 s].
TEST(RepliesTest, OverloadedReplyClampsItsRetryHint) {
  const v1::Reply reply = OverloadedReply(5, {"the queue is full", 250.2});
  EXPECT_EQ(reply.request_id(), 5u);
  EXPECT_EQ(reply.status(), v1::OVERLOADED);
  EXPECT_EQ(reply.error(), "server is overloaded: the queue is full; retry later");
  EXPECT_EQ(reply.retry_after_ms(), 251u);
  EXPECT_EQ(OverloadedReply(5, {"x", 0}).retry_after_ms(), 10u);
  EXPECT_EQ(OverloadedReply(5, {"x", -40}).retry_after_ms(), 10u);
  EXPECT_EQ(OverloadedReply(5, {"x", 10000}).retry_after_ms(), 10000u);
  EXPECT_EQ(OverloadedReply(5, {"x", 1e12}).retry_after_ms(), 10000u);
}

// A request of this protocol or an older one is served; a newer one is UNIMPLEMENTED
// naming both versions, marked retry_elsewhere only in worker mode.
TEST(RepliesTest, ProtocolRefusalOnlyForANewerProtocol) {
  v1::Request request;
  request.set_request_id(9);
  EXPECT_FALSE(ProtocolRefusal(request, false).has_value());  // 0: a client that did not say
  request.set_protocol(kProtocolVersion);
  EXPECT_FALSE(ProtocolRefusal(request, true).has_value());
  request.set_protocol(kProtocolVersion + 1);
  for (const bool worker_mode : {false, true}) {
    const auto refusal = ProtocolRefusal(request, worker_mode);
    ASSERT_TRUE(refusal.has_value());
    EXPECT_EQ(refusal->request_id(), 9u);
    EXPECT_EQ(refusal->status(), v1::UNIMPLEMENTED);
    EXPECT_NE(refusal->error().find("protocol " + std::to_string(kProtocolVersion + 1) +
                                    "; this server speaks " + std::to_string(kProtocolVersion)),
              std::string::npos)
        << refusal->error();
    EXPECT_EQ(refusal->retry_elsewhere(), worker_mode);
  }
}

// A reply's bytes are the reply stamped with this server's protocol.
TEST(RepliesTest, ReplyBodyStampsTheProtocol) {
  v1::Reply reply = ErrorReply(3, v1::INTERNAL, "boom");
  reply.set_protocol(kProtocolVersion + 7);  // whatever it said, the server's version goes out
  const zmq::message_t body = ReplyBody(reply);
  v1::Reply parsed;
  ASSERT_TRUE(parsed.ParseFromArray(body.data(), static_cast<int>(body.size())));
  EXPECT_EQ(parsed.protocol(), kProtocolVersion);
  EXPECT_EQ(parsed.request_id(), 3u);
  EXPECT_EQ(parsed.status(), v1::INTERNAL);
  EXPECT_EQ(parsed.error(), "boom");
}

// SendReply puts [identity][empty?][reply] on a socket: the empty frame only when the
// request had one.
TEST(RepliesTest, SendReplyFramesTheReply) {
  zmq::context_t context;
  zmq::socket_t pull(context, zmq::socket_type::pull);
  pull.bind("tcp://127.0.0.1:*");
  zmq::socket_t push(context, zmq::socket_type::push);
  push.set(zmq::sockopt::linger, 0);
  push.connect(pull.get(zmq::sockopt::last_endpoint));
  pull.set(zmq::sockopt::rcvtimeo, 20000);
  for (const bool delimited : {true, false}) {
    SCOPED_TRACE(delimited ? "delimited" : "bare");
    zmq::message_t identity = Bytes("peer-1");
    SendReply(push, identity, delimited, ErrorReply(8, v1::OK, ""));
    std::vector<zmq::message_t> frames;
    ASSERT_TRUE(zmq::recv_multipart(pull, std::back_inserter(frames)));
    ASSERT_EQ(frames.size(), delimited ? 3u : 2u);
    EXPECT_EQ(frames[0].to_string(), "peer-1");
    if (delimited) {
      EXPECT_EQ(frames[1].size(), 0u);
    }
    v1::Reply reply;
    ASSERT_TRUE(reply.ParseFromArray(frames.back().data(), static_cast<int>(frames.back().size())));
    EXPECT_EQ(reply.request_id(), 8u);
    EXPECT_EQ(reply.protocol(), kProtocolVersion);
  }
}

}  // namespace
}  // namespace sceneloc
