// CURVE keys for tests that authenticate (a server's or a broker's auth): key pairs written
// as `sceneloc keygen` writes them into a folder, an authorised-clients file over some of
// them, and client options that use one.
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "client/client.h"
#include "common/keys/keys.h"

namespace sceneloc::test {

class TestKeys {
 public:
  // Generates and writes NAME.key and NAME.pub for each name into `dir` (created).
  TestKeys(const std::string& dir, const std::vector<std::string>& names);

  // The path of `file` in the keys folder (e.g. "server.key", "clients.yaml").
  std::string Path(const std::string& file) const;
  const KeyPair& pair(const std::string& name) const { return pairs_.at(name); }
  // Writes clients.yaml listing these keys (name, admin).
  void WriteClients(const std::vector<std::pair<std::string, bool>>& clients) const;
  // Client options with `name`'s key and `server`'s public key (empty name: no CURVE).
  ClientOptions ClientWith(const std::string& name, int timeout_ms,
                           const std::string& server = "server") const;

 private:
  std::string dir_;
  std::map<std::string, KeyPair> pairs_;
};

}  // namespace sceneloc::test
