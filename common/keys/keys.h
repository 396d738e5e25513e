// CURVE key files: the keys that authenticate and encrypt the connection between robots
// and sceneloc-server (ZeroMQ's CurveZMQ: Curve25519 keys, written in Z85, 40 characters).
//
//   NAME.key  a key pair, secret: whoever holds it is NAME. Written with mode 0600.
//               # sceneloc key pair: keep this file secret
//               name: robot-7
//               public_key: "<40 Z85 characters>"
//               secret_key: "<40 Z85 characters>"
//   NAME.pub  the public half alone, to hand out (the server's, to every client; a
//             client's, to the server's operator for the authorised-clients file).
//   clients   the server's authorised-clients file (auth.clients):
//               clients:
//                 - name: robot-7
//                   public_key: "<40 Z85 characters>"
//                 - name: ops
//                   public_key: "<40 Z85 characters>"
//                   admin: true        # may also reload maps
//
// Only libzmq's key functions are used here (zmq_curve_keypair, zmq_z85_decode); no
// sockets. Thread-safe: free functions and immutable objects.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/util/status.h"

namespace sceneloc {

// Z85 text of a 32-byte Curve25519 key.
inline constexpr size_t kZ85KeyLength = 40;

struct KeyPair {
  std::string name;
  std::string public_key;  // Z85
  std::string secret_key;  // Z85; empty when read from a .pub file
};

// True when libzmq was built with CURVE (Debian's libzmq5 is, with libsodium).
bool CurveAvailable();

// A fresh key pair named `name` (letters, digits, '.', '_', '-'; 1..64 characters).
// Errors: a bad name (InvalidArgument), no CURVE in libzmq (Unimplemented).
StatusOr<KeyPair> GenerateKeyPair(const std::string& name);

// Writes dir/NAME.key (mode 0600) and dir/NAME.pub. Refuses (AlreadyExists as
// FailedPrecondition) to overwrite either file unless `overwrite`. IoError names the file.
Status WriteKeyPair(const KeyPair& pair, const std::string& dir, bool overwrite);

// Reads a .key or .pub file. `need_secret`: a file without a secret key is an error (the
// server's own key, a client's own key). Errors name the file: NotFound, InvalidArgument
// (not YAML, a missing or malformed key, a public key that does not match the secret one).
StatusOr<KeyPair> ReadKeyFile(const std::string& path, bool need_secret);

// Whether `z85` is 40 Z85 characters that decode to a key.
bool IsZ85Key(const std::string& z85);

// The server's authorised-clients file, parsed.
class AuthorisedKeys {
 public:
  struct Entry {
    std::string name;
    std::string public_key;  // Z85
    bool admin = false;
  };

  // Errors name the file and the entry: NotFound, InvalidArgument (not YAML, no `clients`
  // list, an entry without a name or with a malformed key, an unknown field, a name or
  // key listed twice).
  static StatusOr<std::shared_ptr<const AuthorisedKeys>> Load(const std::string& path);
  static StatusOr<std::shared_ptr<const AuthorisedKeys>> Parse(const std::string& yaml,
                                                               const std::string& source);

  // The entry of a client's 32-byte binary public key (as ZAP hands it over), or null.
  const Entry* FindBinary(const std::string& key32) const;
  // The entry named `name`, or null.
  const Entry* FindName(const std::string& name) const;
  size_t size() const { return entries_.size(); }
  const std::string& source() const { return source_; }

 private:
  std::string source_;
  std::vector<Entry> entries_;
  std::map<std::string, size_t> by_binary_key_;
  std::map<std::string, size_t> by_name_;
};

}  // namespace sceneloc
