#include "server/zap_handler.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <vector>

namespace sceneloc {
namespace {

// libzmq asks the ZAP handler at this fixed endpoint of the socket's context.
constexpr char kZapEndpoint[] = "inproc://zeromq.zap.01";
// How often the handler thread checks whether it should stop.
constexpr std::chrono::milliseconds kPollInterval(100);

std::string Text(const zmq::message_t& m) { return std::string(m.data<char>(), m.size()); }

}  // namespace

StatusOr<std::unique_ptr<ZapHandler>> ZapHandler::Start(zmq::context_t& context,
                                                        const AuthOptions& options) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  SCENELOC_ASSIGN_OR_RETURN(KeyPair key, ReadKeyFile(options.server_key, /*need_secret=*/true));
  SCENELOC_ASSIGN_OR_RETURN(auto clients, AuthorisedKeys::Load(options.clients));
  std::unique_ptr<ZapHandler> handler(
      new ZapHandler(context, options, std::move(key), std::move(clients)));
  try {
    handler->socket_.set(zmq::sockopt::linger, 0);
    handler->socket_.bind(kZapEndpoint);
  } catch (const zmq::error_t& e) {
    return IoError(std::string("cannot bind the ZAP handler: ") + e.what());
  }
  handler->thread_ = std::thread([h = handler.get()] { h->Loop(); });
  spdlog::info("auth: CURVE on, server key '{}' ({}), {} authorised client key(s) from {}",
               handler->server_key_.name, handler->server_key_.public_key,
               handler->clients()->size(), options.clients);
  return handler;
}

ZapHandler::ZapHandler(zmq::context_t& context, AuthOptions options, KeyPair server_key,
                       std::shared_ptr<const AuthorisedKeys> clients)
    : options_(std::move(options)),
      server_key_(std::move(server_key)),
      socket_(context, zmq::socket_type::rep),
      clients_(std::move(clients)) {}

ZapHandler::~ZapHandler() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

std::shared_ptr<const AuthorisedKeys> ZapHandler::clients() const {
  MutexLock lock(&mutex_);
  return clients_;
}

ZapHandler::Role ZapHandler::RoleOf(const std::string& user_id) const {
  const AuthorisedKeys::Entry* entry = nullptr;
  const auto keys = clients();
  entry = keys->FindName(user_id);
  if (entry == nullptr) return Role::kUnknown;
  return entry->admin ? Role::kAdmin : Role::kClient;
}

Status ZapHandler::ReloadClients() {
  auto loaded = AuthorisedKeys::Load(options_.clients);
  if (!loaded.ok()) {
    spdlog::error("auth: clients file not reloaded, the old list stays in force: {}",
                  loaded.status().message());
    return loaded.status();
  }
  spdlog::info("auth: {} authorised client key(s) from {}", (*loaded)->size(), options_.clients);
  MutexLock lock(&mutex_);
  clients_ = std::move(loaded).value();
  return Status::Ok();
}

void ZapHandler::Loop() {
  while (!stop_) {
    try {
      zmq::pollitem_t item{socket_.handle(), 0, ZMQ_POLLIN, 0};
      if (zmq::poll(&item, 1, kPollInterval) > 0) Answer();
    } catch (const std::exception& e) {
      // A REP socket that failed mid-exchange would stay stuck: the next recv resets it.
      spdlog::error("auth: ZAP handler: {}", e.what());
    }
  }
  socket_.close();
}

// One ZAP exchange: [version, request_id, domain, address, identity, mechanism,
// credentials...] in, [version, request_id, status_code, status_text, user_id, metadata] out.
void ZapHandler::Answer() {
  std::vector<zmq::message_t> frames;
  bool more = true;
  while (more) {
    zmq::message_t frame;
    if (!socket_.recv(frame, zmq::recv_flags::none)) return;
    more = frame.more();
    frames.push_back(std::move(frame));
  }
  std::string code = "400", text = "not authorised", user_id;
  if (frames.size() < 7 || Text(frames[0]) != "1.0") {
    code = "500";
    text = "malformed ZAP request";
  } else if (Text(frames[5]) != "CURVE") {
    text = "only CURVE clients are admitted";
  } else if (const auto* entry = clients()->FindBinary(Text(frames[6]))) {
    code = "200";
    text = "OK";
    user_id = entry->name;
  }
  if (code == "200") {
    ++admitted_;
    spdlog::debug("auth: admitted '{}' from {}", user_id, frames.size() > 3 ? Text(frames[3]) : "");
  } else {
    ++refused_;
    const auto now = std::chrono::steady_clock::now();
    if (now - last_refusal_log_ >= std::chrono::seconds(1)) {
      spdlog::info("auth: refused a {} client from {}: {}{}",
                   frames.size() > 5 ? Text(frames[5]) : "?",
                   frames.size() > 3 ? Text(frames[3]) : "?", text,
                   unlogged_refusals_ > 0
                       ? " (and " + std::to_string(unlogged_refusals_) + " not logged before it)"
                       : std::string());
      last_refusal_log_ = now;
      unlogged_refusals_ = 0;
    } else {
      ++unlogged_refusals_;
    }
  }
  const std::string version = "1.0";
  const std::string request_id = frames.size() > 1 ? Text(frames[1]) : std::string();
  socket_.send(zmq::buffer(version), zmq::send_flags::sndmore);
  socket_.send(zmq::buffer(request_id), zmq::send_flags::sndmore);
  socket_.send(zmq::buffer(code), zmq::send_flags::sndmore);
  socket_.send(zmq::buffer(text), zmq::send_flags::sndmore);
  socket_.send(zmq::buffer(user_id), zmq::send_flags::sndmore);
  socket_.send(zmq::message_t(), zmq::send_flags::none);
}

void ZapHandler::Secure(zmq::socket_t* socket) const {
  socket->set(zmq::sockopt::curve_server, true);
  socket->set(zmq::sockopt::curve_secretkey, server_key_.secret_key);
  socket->set(zmq::sockopt::zap_domain, "sceneloc");
}

}  // namespace sceneloc
