#include "client/client.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <random>
#include <thread>
#include <zmq.hpp>

#include "client/fleet_routes.h"
#include "common/keys/keys.h"

namespace sceneloc {
namespace {

StatusCode EngineCode(v1::StatusCode code) {
  switch (code) {
    case v1::INVALID_ARGUMENT:
      return StatusCode::kInvalidArgument;
    case v1::NOT_FOUND:
      return StatusCode::kNotFound;
    case v1::OVERLOADED:
    case v1::RESOURCE_EXHAUSTED:
      return StatusCode::kResourceExhausted;
    case v1::DATA_LOSS:
      return StatusCode::kDataLoss;
    case v1::FAILED_PRECONDITION:
    case v1::UNAVAILABLE:
      return StatusCode::kFailedPrecondition;
    case v1::UNIMPLEMENTED:
      return StatusCode::kUnimplemented;
    case v1::DEADLINE_EXCEEDED:
      return StatusCode::kDeadlineExceeded;
    case v1::PERMISSION_DENIED:
      return StatusCode::kPermissionDenied;
    default:
      return StatusCode::kInternal;
  }
}

class ZmqClient final : public Client {
 public:
  ZmqClient(std::string endpoint, const ClientOptions& options)
      : endpoint_(std::move(endpoint)), options_(options), context_(1) {
    // Ids start at a random point so replies meant for an earlier client on the same
    // server connection (there are none today) could never be mistaken for ours.
    next_id_ = std::random_device()() | 1u;
  }

  // Reads the CURVE keys of the options, when set.
  Status ReadKeys() {
    if (options_.key_file.empty()) return Status::Ok();
    SCENELOC_ASSIGN_OR_RETURN(own_key_, ReadKeyFile(options_.key_file, /*need_secret=*/true));
    SCENELOC_ASSIGN_OR_RETURN(server_key_,
                              ReadKeyFile(options_.server_key_file, /*need_secret=*/false));
    return Status::Ok();
  }

  Status Open() {
    try {
      socket_ = zmq::socket_t(context_, zmq::socket_type::dealer);
      socket_.set(zmq::sockopt::linger, 0);
      if (!own_key_.public_key.empty()) {
        socket_.set(zmq::sockopt::curve_serverkey, server_key_.public_key);
        socket_.set(zmq::sockopt::curve_publickey, own_key_.public_key);
        socket_.set(zmq::sockopt::curve_secretkey, own_key_.secret_key);
      }
      socket_.connect(endpoint_);
    } catch (const zmq::error_t& e) {
      return InvalidArgument("cannot connect to '" + endpoint_ + "': " + e.what());
    }
    return Status::Ok();
  }

  StatusOr<v1::Reply> Call(v1::Request request) override {
    request.set_request_id(next_id_++);
    request.set_protocol(kProtocolVersion);
    const std::string session = CarrySessionState(&request);
    StatusOr<v1::Reply> reply = Send(request);
    // OVERLOADED means nothing was done (a session's frame was not added): asking again is
    // safe. Wait what the server suggests, jittered, within overload_wait_ms in all.
    using Clock = std::chrono::steady_clock;
    const Clock::time_point give_up =
        Clock::now() + std::chrono::milliseconds(options_.overload_wait_ms);
    while (reply.ok() && reply->status() == v1::OVERLOADED) {
      const double hint_ms = std::max<double>(reply->retry_after_ms(), 10.0);
      const auto wait = std::chrono::duration_cast<Clock::duration>(
          std::chrono::duration<double, std::milli>(hint_ms * jitter_(random_)));
      if (Clock::now() + wait > give_up) break;
      std::this_thread::sleep_for(wait);
      ++overload_retries_;
      request.set_request_id(next_id_++);
      reply = Send(request);
    }
    if (!session.empty()) KeepSessionState(session, reply);
    return reply;
  }

  int64_t overload_retries() const override { return overload_retries_; }
  int64_t retries() const override { return retries_; }

  // A localise request of a session carries the state of that session's last reply (unless
  // it sets one itself or resets). Returns the session's key here ("" for none).
  std::string CarrySessionState(v1::Request* request) const {
    if (!request->has_localise() || request->localise().session().empty()) return {};
    v1::LocaliseRequest* localise = request->mutable_localise();
    std::string key = localise->map() + '\0' + localise->session();
    const auto it = session_states_.find(key);
    if (it != session_states_.end() && localise->session_state().empty() &&
        !localise->reset_session()) {
      localise->set_session_state(it->second);
    }
    return key;
  }

  // Remembers the session's state from its reply; forgets it after an error reply (the
  // server then continues from the state it keeps, if any).
  void KeepSessionState(const std::string& key, const StatusOr<v1::Reply>& reply) {
    if (reply.ok() && reply->status() == v1::OK && reply->localise().has_session()) {
      session_states_[key] = reply->localise().session().state();
    } else if (reply.ok()) {
      session_states_.erase(key);
    }
  }

  StatusOr<v1::Reply> Send(const v1::Request& request) {
    const std::string bytes = request.SerializeAsString();
    for (int attempt = 0; attempt <= options_.retries; ++attempt) {
      if (attempt > 0) {
        SCENELOC_RETURN_IF_ERROR(Open());  // a fresh socket per retry
        ++retries_;
      }
      try {
        socket_.send(zmq::message_t(), zmq::send_flags::sndmore);
        socket_.send(zmq::buffer(bytes), zmq::send_flags::none);
        auto reply = AwaitReply(request.request_id());
        // UNAVAILABLE: the server (a worker behind a broker, say) is shutting down and did
        // nothing; a fresh socket may reach one that is not, as after a timeout. The same
        // for a worker that says another may do the request (Reply.retry_elsewhere).
        const bool elsewhere =
            reply && reply->ok() &&
            ((*reply)->status() == v1::UNAVAILABLE || (*reply)->retry_elsewhere());
        if (elsewhere && attempt < options_.retries) {
          std::this_thread::sleep_for(std::chrono::milliseconds(50));
          continue;
        }
        if (reply) return *std::move(reply);
      } catch (const zmq::error_t& e) {
        return IoError("ZeroMQ error talking to '" + endpoint_ + "': " + e.what());
      }
    }
    return IoError("no reply from '" + endpoint_ + "' within " +
                   std::to_string(options_.timeout_ms) + " ms (" +
                   std::to_string(options_.retries + 1) + " attempts)");
  }

  StatusOr<v1::LocaliseReply> Localise(const std::string& map, const std::string& jpeg,
                                       const LocaliseOptions& options) override {
    v1::Request request = LocaliseRequest(map, options);
    request.mutable_localise()->set_jpeg(jpeg);
    return Typed(std::move(request), &v1::Reply::localise);
  }

  StatusOr<v1::LocaliseReply> Localise(const std::string& map, const FeatureSet& features,
                                       const LocaliseOptions& options) override {
    v1::Request request = LocaliseRequest(map, options);
    EncodeFeatureSet(features, options.encoding, request.mutable_localise()->mutable_features());
    return Typed(std::move(request), &v1::Reply::localise);
  }

  static v1::Request LocaliseRequest(const std::string& map, const LocaliseOptions& options) {
    v1::Request request;
    request.mutable_localise()->set_map(map);
    request.mutable_localise()->set_top_k(options.top_k);
    if (options.min_confidence)
      request.mutable_localise()->set_min_confidence(*options.min_confidence);
    if (options.camera_scale) request.mutable_localise()->set_camera_scale(*options.camera_scale);
    request.mutable_localise()->set_session(options.session);
    request.mutable_localise()->set_reset_session(options.reset_session);
    return request;
  }

  StatusOr<v1::ListMapsReply> ListMaps() override {
    v1::Request request;
    request.mutable_list_maps();
    return Typed(std::move(request), &v1::Reply::list_maps);
  }

  StatusOr<v1::ReloadMapReply> Reload(const std::string& map) override {
    v1::Request request;
    request.mutable_reload_map()->set_map(map);
    return Typed(std::move(request), &v1::Reply::reload_map);
  }

  StatusOr<v1::StatsReply> Stats() override {
    v1::Request request;
    request.mutable_stats();
    return Typed(std::move(request), &v1::Reply::stats);
  }

  StatusOr<v1::KeptFramesReply> KeptFrames(const v1::KeptFramesRequest& kept) override {
    v1::Request request;
    *request.mutable_kept_frames() = kept;
    return Typed(std::move(request), &v1::Reply::kept_frames);
  }

 private:
  // Waits for the reply to `id` until the attempt's deadline; replies to other ids
  // (late answers to an abandoned attempt) are dropped. nullopt on timeout.
  std::optional<StatusOr<v1::Reply>> AwaitReply(uint64_t id) {
    using Clock = std::chrono::steady_clock;
    const auto deadline = Clock::now() + std::chrono::milliseconds(options_.timeout_ms);
    for (;;) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
      if (left.count() <= 0) return std::nullopt;
      zmq::pollitem_t item{socket_.handle(), 0, ZMQ_POLLIN, 0};
      if (zmq::poll(&item, 1, left) == 0) continue;
      std::vector<zmq::message_t> frames;
      bool more = true;
      while (more) {
        zmq::message_t frame;
        if (!socket_.recv(frame, zmq::recv_flags::none)) break;
        more = frame.more();
        frames.push_back(std::move(frame));
      }
      if (frames.empty()) continue;
      v1::Reply reply;
      const zmq::message_t& body = frames.back();
      if (!reply.ParseFromArray(body.data(), static_cast<int>(body.size()))) {
        return StatusOr<v1::Reply>(Internal("reply from '" + endpoint_ + "' cannot be parsed"));
      }
      if (reply.request_id() != id) continue;
      if (reply.protocol() > kProtocolVersion) {
        return StatusOr<v1::Reply>(Unimplemented(
            "'" + endpoint_ + "' replied in sceneloc protocol " + std::to_string(reply.protocol()) +
            "; this client speaks " + std::to_string(kProtocolVersion) +
            " (upgrade the client, or reach a server of its version)"));
      }
      return StatusOr<v1::Reply>(std::move(reply));
    }
  }

  template <typename T>
  StatusOr<T> Typed(v1::Request request, const T& (v1::Reply::*field)() const) {
    SCENELOC_ASSIGN_OR_RETURN(const v1::Reply reply, Call(std::move(request)));
    if (reply.status() != v1::OK) return ReplyStatus(reply);
    return (reply.*field)();
  }

  const std::string endpoint_;
  const ClientOptions options_;
  zmq::context_t context_;
  zmq::socket_t socket_;
  // The `state` of each session's last reply, by map and session name (CarrySessionState).
  std::map<std::string, std::string> session_states_;
  KeyPair own_key_;     // empty without CURVE
  KeyPair server_key_;  // its public half
  uint64_t next_id_ = 1;
  int64_t overload_retries_ = 0;
  int64_t retries_ = 0;
  std::mt19937 random_{std::random_device()()};
  std::uniform_real_distribution<double> jitter_{1.0, 1.5};
};

// A fleet of groups (fleet_routes.h): one ZmqClient per broker, made on first use, and each
// request sent to its map's.
class RoutedClient final : public Client {
 public:
  RoutedClient(FleetRoutes routes, const ClientOptions& options)
      : routes_(std::move(routes)), options_(options) {}

  StatusOr<v1::Reply> Call(v1::Request request) override {
    std::string map;
    if (request.has_localise()) map = request.localise().map();
    if (request.has_reload_map()) map = request.reload_map().map();
    if (request.has_kept_frames()) map = request.kept_frames().map();
    SCENELOC_ASSIGN_OR_RETURN(Client * client, map.empty() ? First() : For(map));
    return client->Call(std::move(request));
  }

  StatusOr<v1::LocaliseReply> Localise(const std::string& map, const std::string& jpeg,
                                       const LocaliseOptions& options) override {
    SCENELOC_ASSIGN_OR_RETURN(Client * client, For(map));
    return client->Localise(map, jpeg, options);
  }

  StatusOr<v1::LocaliseReply> Localise(const std::string& map, const FeatureSet& features,
                                       const LocaliseOptions& options) override {
    SCENELOC_ASSIGN_OR_RETURN(Client * client, For(map));
    return client->Localise(map, features, options);
  }

  // Every broker's maps together; the first broker that fails makes the call fail.
  StatusOr<v1::ListMapsReply> ListMaps() override {
    v1::ListMapsReply all;
    for (const std::string& endpoint : routes_.Endpoints()) {
      SCENELOC_ASSIGN_OR_RETURN(Client * client, Of(endpoint));
      SCENELOC_ASSIGN_OR_RETURN(const v1::ListMapsReply some, client->ListMaps());
      for (const auto& map : some.maps()) *all.add_maps() = map;
    }
    return all;
  }

  StatusOr<v1::ReloadMapReply> Reload(const std::string& map) override {
    SCENELOC_ASSIGN_OR_RETURN(Client * client, For(map));
    return client->Reload(map);
  }

  // The stats of one worker of the first broker (the default one, when there is one).
  StatusOr<v1::StatsReply> Stats() override {
    SCENELOC_ASSIGN_OR_RETURN(Client * client, First());
    return client->Stats();
  }

  // Asked of the broker serving the map (the first broker for every map); brokers' workers
  // refuse it, saying to read the worker's own folder.
  StatusOr<v1::KeptFramesReply> KeptFrames(const v1::KeptFramesRequest& request) override {
    SCENELOC_ASSIGN_OR_RETURN(Client * client,
                              request.map().empty() ? First() : For(request.map()));
    return client->KeptFrames(request);
  }

  int64_t overload_retries() const override { return Sum(&Client::overload_retries); }
  int64_t retries() const override { return Sum(&Client::retries); }

 private:
  StatusOr<Client*> For(const std::string& map) {
    SCENELOC_ASSIGN_OR_RETURN(const std::string endpoint, routes_.EndpointOf(map));
    return Of(endpoint);
  }
  StatusOr<Client*> First() { return Of(routes_.Endpoints().front()); }
  // A counter summed over the brokers' clients.
  int64_t Sum(int64_t (Client::*counter)() const) const {
    int64_t total = 0;
    for (const auto& [endpoint, client] : clients_) total += (client.get()->*counter)();
    return total;
  }
  // The client of `endpoint`, made on first use; one that cannot be made is not kept.
  StatusOr<Client*> Of(const std::string& endpoint) {
    const auto it = clients_.find(endpoint);
    if (it != clients_.end()) return it->second.get();
    auto client = std::make_unique<ZmqClient>(endpoint, options_);
    SCENELOC_RETURN_IF_ERROR(client->ReadKeys());
    SCENELOC_RETURN_IF_ERROR(client->Open());
    return (clients_[endpoint] = std::move(client)).get();
  }

  const FleetRoutes routes_;
  const ClientOptions options_;
  std::map<std::string, std::unique_ptr<ZmqClient>> clients_;
};

}  // namespace

Status ClientOptions::Validate() const {
  if (timeout_ms < 1) return InvalidArgument("timeout_ms must be >= 1");
  if (retries < 0) return InvalidArgument("retries must be >= 0");
  if (overload_wait_ms < 0) return InvalidArgument("overload_wait_ms must be >= 0");
  if (key_file.empty() != server_key_file.empty()) {
    return InvalidArgument(
        "CURVE needs both key files: this client's key pair (key_file) and the "
        "server's public key (server_key_file)");
  }
  return Status::Ok();
}

Status ReplyStatus(const v1::Reply& reply) {
  if (reply.status() == v1::OK) return Status::Ok();
  return Status(EngineCode(reply.status()),
                v1::StatusCode_Name(reply.status()) + ": " + reply.error());
}

StatusOr<std::unique_ptr<Client>> Client::Connect(const std::string& endpoint,
                                                  const ClientOptions& options) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  if (endpoint.rfind(kRoutesPrefix, 0) == 0) {
    SCENELOC_ASSIGN_OR_RETURN(FleetRoutes routes,
                              ReadFleetRoutes(endpoint.substr(sizeof(kRoutesPrefix) - 1)));
    return std::unique_ptr<Client>(std::make_unique<RoutedClient>(std::move(routes), options));
  }
  auto client = std::make_unique<ZmqClient>(endpoint, options);
  SCENELOC_RETURN_IF_ERROR(client->ReadKeys());
  SCENELOC_RETURN_IF_ERROR(client->Open());
  return std::unique_ptr<Client>(std::move(client));
}

}  // namespace sceneloc
