#include "tests/server/test_keys.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace sceneloc::test {

TestKeys::TestKeys(const std::string& dir, const std::vector<std::string>& names) : dir_(dir) {
  std::filesystem::create_directories(dir_);
  for (const std::string& name : names) {
    auto pair = GenerateKeyPair(name);
    EXPECT_TRUE(pair.ok()) << pair.status().ToString();
    if (!pair.ok()) continue;
    const Status written = WriteKeyPair(*pair, dir_, false);
    EXPECT_TRUE(written.ok()) << written.ToString();
    pairs_[name] = *pair;
  }
}

std::string TestKeys::Path(const std::string& file) const {
  return (std::filesystem::path(dir_) / file).string();
}

void TestKeys::WriteClients(const std::vector<std::pair<std::string, bool>>& clients) const {
  std::ofstream out(Path("clients.yaml"));
  out << "clients:\n";
  for (const auto& [name, admin] : clients) {
    out << "  - name: " << name << "\n    public_key: \"" << pairs_.at(name).public_key << "\"\n"
        << (admin ? "    admin: true\n" : "");
  }
  EXPECT_TRUE(out.good()) << Path("clients.yaml");
}

ClientOptions TestKeys::ClientWith(const std::string& name, int timeout_ms,
                                   const std::string& server) const {
  ClientOptions options;
  options.timeout_ms = timeout_ms;
  options.retries = 0;
  if (!name.empty()) {
    options.key_file = Path(name + ".key");
    options.server_key_file = Path(server + ".pub");
  }
  return options;
}

}  // namespace sceneloc::test
