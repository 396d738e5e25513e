// An authenticated fleet on loopback: sceneloc::Broker with CURVE on its frontend (the same
// clients file a server reads), a real worker behind it, and clients with and without a
// listed key. Also what a worker refuses behind a broker whatever the auth: reload_map.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "client/client.h"
#include "server/broker.h"
#include "tests/server/server_test_support.h"
#include "tests/server/test_keys.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;
using test::kTestMapName;

// A client that gets no answer must not hold the test up for long.
constexpr int kSilentTimeoutMs = 400;

class BrokerAuthTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::make_unique<test::TempMapsDir>("broker_auth");
    keys_ =
        std::make_unique<test::TestKeys>((fs::path(dir_->path()) / "keys").string(),
                                         std::vector<std::string>{"broker", "robot", "stranger"});
    keys_->WriteClients({{"robot", false}});
    options_.frontend = "tcp://127.0.0.1:*";
    options_.backend = "tcp://127.0.0.1:*";
    options_.auth.enabled = true;
    options_.auth.server_key = keys_->Path("broker.key");
    options_.auth.clients = keys_->Path("clients.yaml");
  }

  // Starts the broker and one worker (plain, on the backend) serving the test map.
  void StartFleet() {
    auto broker = Broker::Start(options_);
    ASSERT_TRUE(broker.ok()) << broker.status().ToString();
    broker_ = std::move(broker).value();
    ServerOptions worker = test::TestServerOptions();
    worker.connect = broker_->backend();
    worker.threads = 1;
    worker_ = test::StartTestServer(worker);
    ASSERT_NE(worker_.server, nullptr);
  }

  // A client of the broker with `name`'s key (empty: no CURVE).
  std::unique_ptr<Client> Connect(const std::string& name, int timeout_ms = 20000) {
    auto client = Client::Connect(broker_->frontend(),
                                  keys_->ClientWith(name, timeout_ms * test::kTimeScale, "broker"));
    EXPECT_TRUE(client.ok()) << client.status().ToString();
    return client.ok() ? std::move(client).value() : nullptr;
  }

  static void ExpectNoReply(Client* client, const char* who) {
    const Status status = client->ListMaps().status();
    EXPECT_EQ(status.code(), StatusCode::kIoError) << who << ": " << status.ToString();
    EXPECT_NE(status.message().find("no reply"), std::string::npos) << status.message();
  }

  std::unique_ptr<test::TempMapsDir> dir_;
  std::unique_ptr<test::TestKeys> keys_;
  BrokerOptions options_;
  std::unique_ptr<Broker> broker_;
  test::TestServer worker_;
};

// A listed key is answered by the worker behind the broker; no CURVE, or a key the clients
// file does not list, gets no answer at all.
TEST_F(BrokerAuthTest, OnlyListedKeysReachTheWorkers) {
  StartFleet();
  ASSERT_FALSE(HasFatalFailure());
  auto robot = Connect("robot");
  auto answer = robot->Localise(kTestMapName, test::TourFeatures(4));
  ASSERT_TRUE(answer.ok()) << answer.status().ToString();
  EXPECT_EQ(answer->locations(0).index(), 4);
  ExpectNoReply(Connect("", kSilentTimeoutMs).get(), "no CURVE");
  ExpectNoReply(Connect("stranger", kSilentTimeoutMs).get(), "stranger");
  EXPECT_TRUE(robot->ListMaps().ok());
}

// The clients file re-read (SIGHUP): a key added connects, a key removed cannot connect
// again, while the connection it already had keeps working (the proxy does not read
// requests; documented in broker.h). A file that does not parse changes nothing.
TEST_F(BrokerAuthTest, ReloadedClientsApplyToNewConnections) {
  StartFleet();
  ASSERT_FALSE(HasFatalFailure());
  auto robot = Connect("robot");
  ASSERT_TRUE(robot->ListMaps().ok());

  { std::ofstream(keys_->Path("clients.yaml")) << "clients: [\n"; }
  EXPECT_FALSE(broker_->ReloadClients().ok());
  EXPECT_TRUE(Connect("robot")->ListMaps().ok());

  keys_->WriteClients({{"stranger", false}});
  ASSERT_TRUE(broker_->ReloadClients().ok());
  EXPECT_TRUE(Connect("stranger")->ListMaps().ok());
  ExpectNoReply(Connect("robot", kSilentTimeoutMs).get(), "removed robot, new connection");
  EXPECT_TRUE(robot->ListMaps().ok());
}

// Bad key settings stop the broker's start, naming what is wrong; without auth there is no
// clients file to re-read.
TEST_F(BrokerAuthTest, BadKeySettingsStopTheStart) {
  BrokerOptions options = options_;
  options.auth.server_key = keys_->Path("broker.pub");  // no secret key in it
  auto started = Broker::Start(options);
  ASSERT_FALSE(started.ok());
  EXPECT_NE(started.status().message().find("broker.pub"), std::string::npos)
      << started.status().message();

  options = options_;
  options.auth.clients = keys_->Path("missing.yaml");
  started = Broker::Start(options);
  ASSERT_FALSE(started.ok());
  EXPECT_EQ(started.status().code(), StatusCode::kNotFound);

  options = options_;
  options.auth.clients.clear();
  started = Broker::Start(options);
  ASSERT_FALSE(started.ok());
  EXPECT_NE(started.status().message().find("auth.clients"), std::string::npos);

  options = options_;
  options.auth = AuthOptions();
  started = Broker::Start(options);
  ASSERT_TRUE(started.ok()) << started.status().ToString();
  EXPECT_EQ((*started)->ReloadClients().code(), StatusCode::kFailedPrecondition);
}

// Behind a broker a reload would reach one worker of many (and come from any client):
// every worker refuses it, naming what to do instead, and keeps serving.
TEST_F(BrokerAuthTest, WorkersRefuseReloadThroughTheBroker) {
  options_.auth = AuthOptions();
  StartFleet();
  ASSERT_FALSE(HasFatalFailure());
  auto client = Connect("");
  const Status refused = client->Reload(kTestMapName).status();
  EXPECT_EQ(refused.code(), StatusCode::kFailedPrecondition) << refused.ToString();
  EXPECT_NE(refused.message().find("broker"), std::string::npos) << refused.message();
  EXPECT_NE(refused.message().find("SIGHUP"), std::string::npos) << refused.message();
  auto maps = client->ListMaps();
  ASSERT_TRUE(maps.ok()) << maps.status().ToString();
  ASSERT_EQ(maps->maps_size(), 1);
  EXPECT_EQ(maps->maps(0).version().generation(), 1u);
}

}  // namespace
}  // namespace sceneloc
