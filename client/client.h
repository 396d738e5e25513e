// sceneloc::Client: the C++ side of the wire protocol (proto/sceneloc.proto) for robots,
// tools and tests. One DEALER socket to one server; each call sends a request and waits
// for its reply.
//
// Timeouts and retries: a call waits options.timeout_ms for its reply; on a timeout it
// closes the socket, opens a fresh one and sends the same request again, up to
// options.retries more times (the Lazy Pirate pattern of the ZeroMQ guide). So a server
// that restarts between or during calls is survived; every request kind is safe to
// repeat. An UNAVAILABLE reply (the server is shutting down; nothing was done) is retried
// the same way, after 50 ms, so behind a broker another worker answers; so is a reply
// marked retry_elsewhere (a worker without the map, or of another protocol: its status is
// returned once the retries are spent). A reply of a newer protocol than this client's is
// Unimplemented, naming both versions. Other error replies are never retried, except
// OVERLOADED (nothing was done either): the call waits the server's Reply.retry_after_ms
// (times 1 to 1.5, so that clients refused together do not come back together) and asks
// again, for at most options.overload_wait_ms in all; then the OVERLOADED reply is the
// answer.
//
// Not thread-safe: use one Client per thread (each has its own ZeroMQ context).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "common/features/feature_set.h"
#include "common/util/status.h"
#include "proto/sceneloc.pb.h"
#include "proto/wire.h"

namespace sceneloc {

// Per-request settings of a localise call.
struct LocaliseOptions {
  int top_k = 0;  // ranked locations wanted; 0 = the server's default
  // Answers below this confidence come back with decision UNKNOWN; unset = the server's
  // matching.min_confidence. Outside [0, 1] the server replies INVALID_ARGUMENT.
  std::optional<float> min_confidence;
  // How much larger the robot's camera sees things than the tour's camera did, when known
  // (proto LocaliseRequest.camera_scale: focal length over image width, against the tour
  // camera's; in [0.25, 4], else INVALID_ARGUMENT). Unset = the one the frame's shape
  // implies (the tour's for the tour frame's shape), or in a session the scale it learns.
  std::optional<float> camera_scale;
  // How a feature set's descriptors travel (feature-set calls only). uint8, a third of the
  // bytes, by default: on 100 Gardens Point frames it gave the same answers and confidences
  // as float32, and through a broker it costs half the time (docs/results.md "Fleet (issue
  // 12): the broker's cost is the bytes it passes"). float32 is exact.
  DescriptorEncoding encoding = DescriptorEncoding::kUint8;
  // The robot's session (proto LocaliseRequest.session): calls naming one session are
  // filtered together on the server and the reply's session() holds the filtered answer.
  // Empty = a frame on its own. Send a session's frames one call after another. A call that
  // is retried after a timeout may add its frame to the session twice (a small bias).
  // The client keeps each session's state from its last reply and sends it with the next
  // request (LocaliseRequest.session_state), so any server serving the map continues it.
  std::string session;
  // Forget the session's past before this frame.
  bool reset_session = false;
};

struct ClientOptions {
  // How long one attempt waits for its reply, milliseconds (>= 1).
  int timeout_ms = 5000;
  // Attempts after the first one timed out, each on a fresh socket (>= 0).
  int retries = 2;
  // Longest a call spends waiting out OVERLOADED replies before retrying, milliseconds
  // (>= 0; 0 = return the first OVERLOADED at once). The default covers the server's
  // limits.max_queue_wait_ms; a robot that would rather drop a stale frame sets it lower.
  int overload_wait_ms = 1000;
  // CURVE (common/keys/keys.h), for a server with auth.enabled: this client's key pair
  // (a .key file) and the server's public key (its .pub, or its .key). Both or neither.
  // A client whose key the server does not list gets no reply at all: its calls time out.
  std::string key_file;
  std::string server_key_file;

  Status Validate() const;
};

class Client {
 public:
  virtual ~Client() = default;

  // Connects (lazily, as ZeroMQ does: no server needs to be up yet) to `endpoint`; or,
  // given "routes:FILE", to a fleet of groups (client/fleet_routes.h): each request goes
  // to the broker serving its map, list_maps gathers every broker's maps, stats asks the
  // first (default) broker. Errors: invalid options or a malformed endpoint
  // (InvalidArgument); a key file that cannot be read (its ReadKeyFile error, naming it);
  // a routes file that cannot be read or parsed (ReadFleetRoutes's error). A map the
  // routes do not place fails its call with NotFound naming the routes file.
  static StatusOr<std::unique_ptr<Client>> Connect(const std::string& endpoint,
                                                   const ClientOptions& options = {});

  // Sends `request` (its request_id is overwritten with a fresh one) and returns the
  // server's reply, whatever its status. Errors: IoError when no reply came after every
  // attempt; Internal for a reply that cannot be parsed.
  virtual StatusOr<v1::Reply> Call(v1::Request request) = 0;

  // The typed calls: an error reply becomes a status whose message starts with the wire
  // status name ("NOT_FOUND: no map named 'x'"), with the nearest engine code. A place the
  // map does not know is not an error: the reply's decision() is v1::UNKNOWN.
  virtual StatusOr<v1::LocaliseReply> Localise(const std::string& map, const std::string& jpeg,
                                               const LocaliseOptions& options = {}) = 0;
  virtual StatusOr<v1::LocaliseReply> Localise(const std::string& map, const FeatureSet& features,
                                               const LocaliseOptions& options = {}) = 0;
  virtual StatusOr<v1::ListMapsReply> ListMaps() = 0;
  virtual StatusOr<v1::ReloadMapReply> Reload(const std::string& map) = 0;
  virtual StatusOr<v1::StatsReply> Stats() = 0;
  // The frames the server kept where its maps failed (proto KeptFramesRequest): list, fetch
  // a page of a run, or delete a run. Needs an admin key on a server with auth.enabled.
  virtual StatusOr<v1::KeptFramesReply> KeptFrames(const v1::KeptFramesRequest& request) = 0;

  // OVERLOADED replies this client waited out and asked again after, since it was made.
  virtual int64_t overload_retries() const = 0;
  // Attempts this client sent again after a timeout, an UNAVAILABLE or a retry_elsewhere
  // reply (each on a fresh socket), since it was made.
  virtual int64_t retries() const = 0;
};

// The engine status for a non-OK wire reply: "<STATUS>: <error>".
Status ReplyStatus(const v1::Reply& reply);

}  // namespace sceneloc
