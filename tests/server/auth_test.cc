// CURVE and the authorised-clients file on a real server, through real sockets: who gets
// answers, who gets nothing, who may reload, and a key revoked while connected.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <zmq.hpp>
#include <zmq_addon.hpp>

#include "client/client.h"
#include "common/keys/keys.h"
#include "tests/server/server_test_support.h"
#include "tests/server/test_keys.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;
using test::kTestMapName;

// A client that gets no answer must not hold the test up for long.
constexpr int kSilentTimeoutMs = 400;

class AuthTest : public ::testing::Test {
 protected:
  void SetUp() override {
    maps_ = std::make_unique<test::TempMapsDir>("auth");
    keys_ = std::make_unique<test::TestKeys>(
        (fs::path(maps_->path()) / "keys").string(),
        std::vector<std::string>{"server", "robot", "ops", "stranger"});
    WriteClients({{"robot", false}, {"ops", true}});
    options_ = test::TestServerOptions();
    options_.maps_dir = maps_->path();
    options_.watch_maps = false;
    options_.auth.enabled = true;
    options_.auth.server_key = Key("server.key");
    options_.auth.clients = Key("clients.yaml");
  }

  std::string Key(const std::string& file) const { return keys_->Path(file); }
  void WriteClients(const std::vector<std::pair<std::string, bool>>& clients) {
    keys_->WriteClients(clients);
  }

  // A client with `name`'s key (empty: no CURVE at all).
  std::unique_ptr<Client> Connect(const std::string& endpoint, const std::string& name,
                                  int timeout_ms = 20000) {
    auto client = Client::Connect(endpoint, keys_->ClientWith(name, timeout_ms));
    EXPECT_TRUE(client.ok()) << client.status().ToString();
    return client.ok() ? std::move(client).value() : nullptr;
  }

  std::unique_ptr<test::TempMapsDir> maps_;
  std::unique_ptr<test::TestKeys> keys_;
  ServerOptions options_;
};

TEST_F(AuthTest, OnlyListedKeysAreAnswered) {
  test::TestServer server = test::StartTestServerOnDir(options_);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());

  auto robot = Connect(server.endpoint, "robot");
  auto maps = robot->ListMaps();
  ASSERT_TRUE(maps.ok()) << maps.status().ToString();
  ASSERT_EQ(maps->maps_size(), 1);
  auto answer = robot->Localise(kTestMapName, test::TourJpegs()[3]);
  ASSERT_TRUE(answer.ok()) << answer.status().ToString();
  EXPECT_NEAR(answer->locations(0).index(), 3, 1);

  // No CURVE, or a key the server does not list: no answer at all, not even an error.
  for (const char* who : {"", "stranger"}) {
    auto outsider = Connect(server.endpoint, who, kSilentTimeoutMs);
    const Status status = outsider->ListMaps().status();
    EXPECT_EQ(status.code(), StatusCode::kIoError) << who << ": " << status.ToString();
    EXPECT_NE(status.message().find("no reply"), std::string::npos) << status.message();
  }
  // The robot is served throughout.
  EXPECT_TRUE(robot->ListMaps().ok());
}

TEST_F(AuthTest, ReloadNeedsAnAdminKey) {
  test::TestServer server = test::StartTestServerOnDir(options_);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  const Status refused = Connect(server.endpoint, "robot")->Reload(kTestMapName).status();
  EXPECT_EQ(refused.code(), StatusCode::kPermissionDenied) << refused.ToString();
  EXPECT_NE(refused.message().find("admin"), std::string::npos) << refused.message();
  auto reloaded = Connect(server.endpoint, "ops")->Reload(kTestMapName);
  ASSERT_TRUE(reloaded.ok()) << reloaded.status().ToString();
  EXPECT_EQ(reloaded->map().version().generation(), 2u);
}

// Kept frames are other robots' camera frames: an admin key only.
TEST_F(AuthTest, KeptFramesNeedAnAdminKey) {
  test::TestServer server = test::StartTestServerOnDir(options_);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  v1::KeptFramesRequest list;
  const Status refused = Connect(server.endpoint, "robot")->KeptFrames(list).status();
  EXPECT_EQ(refused.code(), StatusCode::kPermissionDenied) << refused.ToString();
  EXPECT_NE(refused.message().find("kept_frames needs an admin key"), std::string::npos)
      << refused.message();
  // The admin gets past the key check, to a server that keeps no frames.
  const Status none = Connect(server.endpoint, "ops")->KeptFrames(list).status();
  EXPECT_EQ(none.code(), StatusCode::kFailedPrecondition) << none.ToString();
  EXPECT_NE(none.message().find("keep_frames.dir"), std::string::npos) << none.message();
}

// Sessions are kept per key: two keys using one session name have two sessions, so one
// robot's key cannot read or disturb another's.
TEST_F(AuthTest, SessionsAreKeptPerKey) {
  test::TestServer server = test::StartTestServerOnDir(options_);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  auto robot = Connect(server.endpoint, "robot");
  auto ops = Connect(server.endpoint, "ops");
  LocaliseOptions session;
  session.session = "shared-name";
  for (int i = 0; i < 3; ++i) {
    auto answer = robot->Localise(kTestMapName, test::TourFeatures(i), session);
    ASSERT_TRUE(answer.ok()) << answer.status().ToString();
    EXPECT_EQ(answer->session().frames(), static_cast<uint32_t>(i + 1));
  }
  auto other = ops->Localise(kTestMapName, test::TourFeatures(9), session);
  ASSERT_TRUE(other.ok()) << other.status().ToString();
  EXPECT_EQ(other->session().start(), v1::NEW);
  EXPECT_EQ(other->session().frames(), 1u);
  auto again = robot->Localise(kTestMapName, test::TourFeatures(3), session);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->session().frames(), 4u);
}

TEST_F(AuthTest, ARevokedKeyIsRefusedOnItsOpenConnection) {
  test::TestServer server = test::StartTestServerOnDir(options_);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  auto robot = Connect(server.endpoint, "robot");
  auto ops = Connect(server.endpoint, "ops");
  ASSERT_TRUE(robot->ListMaps().ok());

  // A clients file that does not parse leaves the old list in force.
  { std::ofstream(Key("clients.yaml")) << "clients: [\n"; }
  server.server->ReloadAll();
  ASSERT_TRUE(server.server->WaitForLoader(std::chrono::seconds(20)));
  EXPECT_TRUE(robot->ListMaps().ok());

  WriteClients({{"ops", true}});
  server.server->ReloadAll();  // what SIGHUP does
  ASSERT_TRUE(server.server->WaitForLoader(std::chrono::seconds(20)));
  const Status revoked = robot->ListMaps().status();
  EXPECT_EQ(revoked.code(), StatusCode::kPermissionDenied) << revoked.ToString();
  EXPECT_NE(revoked.message().find("'robot'"), std::string::npos) << revoked.message();
  EXPECT_TRUE(ops->ListMaps().ok());
  // A new connection with the revoked key gets nothing.
  EXPECT_EQ(Connect(server.endpoint, "robot", kSilentTimeoutMs)->ListMaps().status().code(),
            StatusCode::kIoError);
}

// With auth on, a key is one client however many connections it opens: its requests in
// flight over all of them are capped (limits.max_in_flight_per_key), so a few hundred
// connections sending and never reading cannot take the queue from another key's robot.
TEST_F(AuthTest, ManyConnectionsOfOneKeyShareItsLimit) {
  options_.threads = 1;
  options_.limits.max_in_flight_per_key = 3;
  test::TestServer server = test::StartTestServerOnDir(options_);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  zmq::context_t context;
  constexpr int kConnections = 8;
  std::vector<zmq::socket_t> sockets;
  v1::Request request;
  request.mutable_localise()->set_map(kTestMapName);
  request.mutable_localise()->set_jpeg(test::TourJpegs()[2]);
  for (int c = 0; c < kConnections; ++c) {
    zmq::socket_t& socket = sockets.emplace_back(context, zmq::socket_type::dealer);
    socket.set(zmq::sockopt::linger, 0);
    socket.set(zmq::sockopt::curve_serverkey, keys_->pair("server").public_key);
    socket.set(zmq::sockopt::curve_publickey, keys_->pair("robot").public_key);
    socket.set(zmq::sockopt::curve_secretkey, keys_->pair("robot").secret_key);
    socket.connect(server.endpoint);
    request.set_request_id(static_cast<uint64_t>(c + 1));
    socket.send(zmq::message_t(), zmq::send_flags::sndmore);
    socket.send(zmq::buffer(request.SerializeAsString()), zmq::send_flags::none);
  }
  // Another key's robot is served meanwhile.
  auto ops = Connect(server.endpoint, "ops");
  auto served = ops->Localise(kTestMapName, test::TourFeatures(5));
  ASSERT_TRUE(served.ok()) << served.status().ToString();
  EXPECT_EQ(served->locations(0).index(), 5);

  int ok = 0, refused = 0;
  for (zmq::socket_t& socket : sockets) {
    zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
    ASSERT_GT(zmq::poll(&item, 1, std::chrono::seconds(60)), 0) << "a request got no reply";
    std::vector<zmq::message_t> parts;
    ASSERT_TRUE(zmq::recv_multipart(socket, std::back_inserter(parts)));
    v1::Reply reply;
    ASSERT_TRUE(reply.ParseFromArray(parts.back().data(), static_cast<int>(parts.back().size())));
    if (reply.status() == v1::OK) {
      ++ok;
      continue;
    }
    ++refused;
    EXPECT_EQ(reply.status(), v1::OVERLOADED) << reply.error();
    EXPECT_NE(reply.error().find("key 'robot'"), std::string::npos) << reply.error();
    EXPECT_NE(reply.error().find("limits.max_in_flight_per_key"), std::string::npos)
        << reply.error();
    EXPECT_GE(reply.retry_after_ms(), 10u);
  }
  EXPECT_GE(ok, 3);
  EXPECT_GE(refused, 1);
  // Once they are answered, the key may send again.
  auto later = Connect(server.endpoint, "robot")->Localise(kTestMapName, test::TourFeatures(6));
  ASSERT_TRUE(later.ok()) << later.status().ToString();
}

TEST_F(AuthTest, BadKeySettingsStopTheStartWithTheirName) {
  ServerOptions options = options_;
  options.auth.server_key = Key("server.pub");  // no secret key in it
  MapRegistry registry(MapRegistry::Options{});
  auto started = Server::Start(options, &registry);
  ASSERT_FALSE(started.ok());
  EXPECT_NE(started.status().message().find("server.pub"), std::string::npos)
      << started.status().message();

  options = options_;
  options.auth.clients = Key("missing.yaml");
  started = Server::Start(options, &registry);
  ASSERT_FALSE(started.ok());
  EXPECT_EQ(started.status().code(), StatusCode::kNotFound);

  options = options_;
  options.auth.server_key.clear();
  started = Server::Start(options, &registry);
  ASSERT_FALSE(started.ok());
  EXPECT_NE(started.status().message().find("auth.server_key"), std::string::npos);

  // A client given only one of its two key files is refused before it sends anything.
  ClientOptions client;
  client.key_file = Key("robot.key");
  EXPECT_EQ(Client::Connect("tcp://127.0.0.1:1", client).status().code(),
            StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace sceneloc
