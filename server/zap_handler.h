// Who may talk to the server: the ZAP handler (ZeroMQ RFC 27) behind CURVE on the
// server's socket, when auth.enabled.
//
//   client ──CURVE handshake──▶ ROUTER ──ZAP request (client's public key)──▶ ZapHandler
//                                      ◀── 200 + User-Id = the key's name ────┘  or 400
//
// A client whose public key is not in auth.clients never completes the handshake: it gets
// no answer at all (its requests are never read). An admitted client's requests carry its
// key's name (the message's "User-Id" property); the I/O thread asks Role() for every
// request, so a key removed from the file and reloaded (SIGHUP) is refused at once, even
// on a connection that was admitted before.
//
// Thread-safe: Role() and ReloadClients() may be called from any thread; the handler's
// own thread owns its socket.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <zmq.hpp>

#include "common/keys/keys.h"
#include "common/util/mutex.h"
#include "common/util/status.h"
#include "common/util/thread_annotations.h"
#include "server/server_options.h"

namespace sceneloc {

class ZapHandler {
 public:
  enum class Role { kUnknown, kClient, kAdmin };

  // Reads the server key and the clients file (errors name them) and binds the ZAP
  // endpoint in `context`. Call before the server socket binds, so that no connection is
  // ever admitted without a check.
  static StatusOr<std::unique_ptr<ZapHandler>> Start(zmq::context_t& context,
                                                     const AuthOptions& options);
  ~ZapHandler();  // stops and joins the handler thread

  const KeyPair& server_key() const { return server_key_; }
  // Makes `socket` a CURVE server with this key whose connections this handler admits.
  // Call before it binds. Throws zmq::error_t as socket options do.
  void Secure(zmq::socket_t* socket) const;
  // The role of the key named `user_id` in the clients file as it is now.
  Role RoleOf(const std::string& user_id) const EXCLUDES(mutex_);
  // Re-reads the clients file; on an error the old list stays in force.
  Status ReloadClients() EXCLUDES(mutex_);

  uint64_t admitted() const { return admitted_; }
  uint64_t refused() const { return refused_; }

 private:
  ZapHandler(zmq::context_t& context, AuthOptions options, KeyPair server_key,
             std::shared_ptr<const AuthorisedKeys> clients);
  void Loop() EXCLUDES(mutex_);
  void Answer() EXCLUDES(mutex_);
  // The clients file as last loaded: a snapshot the caller reads without the lock.
  std::shared_ptr<const AuthorisedKeys> clients() const EXCLUDES(mutex_);

  // Constant after construction.
  const AuthOptions options_;
  const KeyPair server_key_;

  // Handler thread only, once it runs (Start() binds the socket before).
  zmq::socket_t socket_;
  // Refusals are logged at most once a second (a flood of handshakes must not flood the
  // log).
  std::chrono::steady_clock::time_point last_refusal_log_{};
  uint64_t unlogged_refusals_ = 0;

  // Any thread, without a lock.
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> admitted_{0};
  std::atomic<uint64_t> refused_{0};

  mutable Mutex mutex_;
  // Guarded by mutex_.
  std::shared_ptr<const AuthorisedKeys> clients_ GUARDED_BY(mutex_);

  std::thread thread_;  // set by Start(), joined by the destructor
};

}  // namespace sceneloc
