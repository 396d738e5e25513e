// The ZAP handler (server/zap_handler.h), asked directly over ZAP (RFC 27) in its own
// ZeroMQ context: who is admitted under which name, roles, reloading the clients file, and
// the errors of bad key settings.
#include "server/zap_handler.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <zmq.hpp>

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

// The reply's status code, status text and user id.
struct ZapReply {
  std::string code, text, user_id;
};

class ZapHandlerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) /
           ("zap_handler_test_" + std::to_string(::getpid()) + "_" + test->name());
    fs::remove_all(dir_);
    for (const char* name : {"server", "robot", "ops", "stranger"}) {
      auto pair = GenerateKeyPair(name);
      ASSERT_TRUE(pair.ok());
      ASSERT_TRUE(WriteKeyPair(*pair, dir_.string(), false).ok());
      pairs_[name] = *pair;
    }
    WriteClients({{"robot", false}, {"ops", true}});
    options_.enabled = true;
    options_.server_key = (dir_ / "server.key").string();
    options_.clients = (dir_ / "clients.yaml").string();
  }
  void TearDown() override {
    handler_.reset();
    fs::remove_all(dir_);
  }

  void WriteClients(const std::vector<std::pair<std::string, bool>>& clients) {
    std::ofstream out(dir_ / "clients.yaml");
    out << "clients:\n";
    for (const auto& [name, admin] : clients) {
      out << "  - name: " << name << "\n    public_key: \"" << pairs_[name].public_key << "\"\n"
          << (admin ? "    admin: true\n" : "");
    }
  }

  void Start() {
    auto handler = ZapHandler::Start(context_, options_);
    ASSERT_TRUE(handler.ok()) << handler.status().ToString();
    handler_ = std::move(handler).value();
  }

  // One ZAP request for `mechanism` with `name`'s public key as the credential.
  ZapReply Ask(const std::string& name, const std::string& mechanism = "CURVE") {
    zmq::socket_t req(context_, zmq::socket_type::req);
    req.set(zmq::sockopt::linger, 0);
    req.set(zmq::sockopt::rcvtimeo, 10000);
    req.connect("inproc://zeromq.zap.01");
    uint8_t key[32];
    zmq_z85_decode(key, pairs_[name].public_key.c_str());
    const std::string frames[] = {"1.0", "7", "", "127.0.0.1", "", mechanism};
    for (const std::string& f : frames) req.send(zmq::buffer(f), zmq::send_flags::sndmore);
    req.send(zmq::buffer(key, sizeof(key)), zmq::send_flags::none);
    std::vector<std::string> reply;
    for (bool more = true; more;) {
      zmq::message_t frame;
      if (!req.recv(frame, zmq::recv_flags::none)) return {};
      more = frame.more();
      reply.push_back(frame.to_string());
    }
    EXPECT_EQ(reply.size(), 6u);
    EXPECT_EQ(reply[1], "7");  // the request id echoed
    return reply.size() < 5 ? ZapReply() : ZapReply{reply[2], reply[3], reply[4]};
  }

  fs::path dir_;
  std::map<std::string, KeyPair> pairs_;
  AuthOptions options_;
  zmq::context_t context_;
  std::unique_ptr<ZapHandler> handler_;
};

// A listed key is admitted (200) under its name; an unlisted key and another mechanism
// are refused (400); the counters follow.
TEST_F(ZapHandlerTest, AdmitsListedKeysByName) {
  Start();
  ASSERT_FALSE(HasFatalFailure());
  const ZapReply robot = Ask("robot");
  EXPECT_EQ(robot.code, "200");
  EXPECT_EQ(robot.user_id, "robot");
  const ZapReply stranger = Ask("stranger");
  EXPECT_EQ(stranger.code, "400");
  EXPECT_EQ(stranger.user_id, "");
  EXPECT_EQ(Ask("robot", "PLAIN").code, "400");
  EXPECT_EQ(handler_->admitted(), 1u);
  EXPECT_EQ(handler_->refused(), 2u);
  EXPECT_EQ(handler_->server_key().public_key, pairs_["server"].public_key);
}

// Roles come from the clients file: admin, client, or unknown.
TEST_F(ZapHandlerTest, RolesFollowTheClientsFile) {
  Start();
  ASSERT_FALSE(HasFatalFailure());
  EXPECT_EQ(handler_->RoleOf("ops"), ZapHandler::Role::kAdmin);
  EXPECT_EQ(handler_->RoleOf("robot"), ZapHandler::Role::kClient);
  EXPECT_EQ(handler_->RoleOf("stranger"), ZapHandler::Role::kUnknown);
  EXPECT_EQ(handler_->RoleOf(""), ZapHandler::Role::kUnknown);
}

// A reloaded clients file takes effect at once; a broken one is refused and the old list
// stays in force.
TEST_F(ZapHandlerTest, ReloadReplacesTheListOrKeepsIt) {
  Start();
  ASSERT_FALSE(HasFatalFailure());
  WriteClients({{"stranger", false}});
  ASSERT_TRUE(handler_->ReloadClients().ok());
  EXPECT_EQ(handler_->RoleOf("robot"), ZapHandler::Role::kUnknown);
  EXPECT_EQ(Ask("stranger").code, "200");
  EXPECT_EQ(Ask("robot").code, "400");
  std::ofstream(dir_ / "clients.yaml") << "clients: [unclosed\n";
  EXPECT_FALSE(handler_->ReloadClients().ok());
  EXPECT_EQ(handler_->RoleOf("stranger"), ZapHandler::Role::kClient);
}

// A missing server key, a public-only key and a missing clients file stop the start.
TEST_F(ZapHandlerTest, BadKeySettingsAreRefused) {
  AuthOptions options = options_;
  options.server_key = (dir_ / "absent.key").string();
  EXPECT_FALSE(ZapHandler::Start(context_, options).ok());
  options.server_key = (dir_ / "server.pub").string();
  EXPECT_FALSE(ZapHandler::Start(context_, options).ok());
  options = options_;
  options.clients = (dir_ / "absent.yaml").string();
  EXPECT_FALSE(ZapHandler::Start(context_, options).ok());
}

}  // namespace
}  // namespace sceneloc
