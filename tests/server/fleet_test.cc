// A fleet on loopback: sceneloc::Broker with real sceneloc servers in worker mode
// (ServerOptions::connect) behind it, and clients that talk to the broker exactly as they
// would to one server. Workers share the work, one may be shut down mid-run and another
// join without a failed request, and a session's frames are answered by different workers.
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <future>
#include <thread>
#include <zmq.hpp>

#include "client/client.h"
#include "client/fleet_routes.h"
#include "proto/wire.h"
#include "server/broker.h"
#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

using test::kTestMapName;

std::unique_ptr<Broker> StartBroker() {
  BrokerOptions options;
  options.frontend = "tcp://127.0.0.1:*";
  options.backend = "tcp://127.0.0.1:*";
  auto broker = Broker::Start(options);
  EXPECT_TRUE(broker.ok()) << broker.status().ToString();
  return broker.ok() ? std::move(broker).value() : nullptr;
}

test::TestServer StartWorker(const Broker& broker) {
  ServerOptions options = test::TestServerOptions();
  options.connect = broker.backend();
  options.threads = 1;
  return test::StartTestServer(options);
}

// A broker with two workers (one thread each) connected to it.
struct Fleet {
  Fleet() : broker(StartBroker()) {
    if (broker == nullptr) return;
    a = StartWorker(*broker);
    b = StartWorker(*broker);
  }
  bool ok() const { return broker != nullptr && a.server != nullptr && b.server != nullptr; }
  std::unique_ptr<Broker> broker;
  test::TestServer a, b;
};

std::unique_ptr<Client> ClientOf(const Broker& broker, int timeout_ms = 5000) {
  ClientOptions options;
  options.timeout_ms = timeout_ms * test::kTimeScale;
  options.retries = 3;
  auto client = Client::Connect(broker.frontend(), options);
  EXPECT_TRUE(client.ok()) << client.status().ToString();
  return client.ok() ? std::move(client).value() : nullptr;
}

// Requests each worker has answered, from two stats requests (the broker hands requests to
// its workers in turn, so consecutive ones reach different workers). Each count includes
// the stats request itself.
std::vector<uint64_t> RequestsPerWorker(Client* client) {
  std::vector<uint64_t> counts;
  for (int i = 0; i < 2; ++i) {
    auto stats = client->Stats();
    EXPECT_TRUE(stats.ok()) << stats.status().ToString();
    if (stats.ok()) counts.push_back(stats->requests());
  }
  return counts;
}

// Two workers behind one broker: every answer right, and both workers did some of it.
TEST(FleetTest, WorkersBehindOneBrokerShareTheWork) {
  Fleet fleet;
  ASSERT_TRUE(fleet.ok());
  const Broker& broker = *fleet.broker;
  EXPECT_EQ(fleet.a.endpoint, broker.backend());
  auto client = ClientOf(broker);
  for (int i = 0; i < 8; ++i) {
    auto answer = client->Localise(kTestMapName, test::TourFeatures(i));
    ASSERT_TRUE(answer.ok()) << answer.status().ToString();
    EXPECT_EQ(answer->locations(0).index(), i);
  }
  const std::vector<uint64_t> counts = RequestsPerWorker(client.get());
  ASSERT_EQ(counts.size(), 2u);
  EXPECT_GE(counts[0], 2u);  // its stats request and at least one localise
  EXPECT_GE(counts[1], 2u);
  EXPECT_EQ(counts[0] + counts[1], 10u);
}

// A worker shut down while a client runs costs no failed request (the client retries on a
// fresh socket after its timeout), and a worker that joins later takes work at once.
TEST(FleetTest, WorkersComeAndGoWithoutAFailedRequest) {
  Fleet fleet;
  ASSERT_TRUE(fleet.ok());
  const Broker& broker = *fleet.broker;
  std::atomic<int> done{0};
  auto run = std::async(std::launch::async, [&] {
    auto client = ClientOf(broker, 1000);
    int failed = 0;
    for (int i = 0; i < 24; ++i) {
      auto answer = client->Localise(kTestMapName, test::TourFeatures(i % 12));
      if (!answer.ok() || answer->locations(0).index() != i % 12) ++failed;
      ++done;
    }
    return failed;
  });
  while (done < 6) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  fleet.a.server.reset();  // drains what it holds and leaves; its registry goes with it
  fleet.a.registry.reset();
  EXPECT_EQ(run.get(), 0);

  test::TestServer c = StartWorker(broker);
  ASSERT_NE(c.server, nullptr);
  auto client = ClientOf(broker);
  for (int i = 0; i < 8; ++i)
    ASSERT_TRUE(client->Localise(kTestMapName, test::TourFeatures(i)).ok());
  const std::vector<uint64_t> counts = RequestsPerWorker(client.get());
  ASSERT_EQ(counts.size(), 2u);
  // One of the two is the newcomer: it has only this client's requests, its share of the 8
  // localise requests (the broker alternates; the newcomer's connection is attached
  // asynchronously, so the first one or two may still go to the other worker) and its
  // stats request. (Asserting exactly half of 4 failed once in CI on that race.)
  EXPECT_GE(std::min(counts[0], counts[1]), 3u);
  EXPECT_LE(std::min(counts[0], counts[1]), 5u);
}

// A robot's session continues across workers: its frames alternate between the two, and
// each answer counts every frame so far (the client carries the session's state).
TEST(FleetTest, ASessionSpansWorkers) {
  Fleet fleet;
  ASSERT_TRUE(fleet.ok());
  const Broker& broker = *fleet.broker;
  auto client = ClientOf(broker);
  LocaliseOptions session;
  session.session = "robot-7";
  for (int i = 0; i < 6; ++i) {
    auto answer = client->Localise(kTestMapName, test::TourFeatures(i), session);
    ASSERT_TRUE(answer.ok()) << answer.status().ToString();
    ASSERT_TRUE(answer->has_session());
    EXPECT_EQ(answer->session().frames(), static_cast<uint32_t>(i + 1)) << "frame " << i;
    EXPECT_NEAR(answer->session().location(), i, 1);
  }
  const std::vector<uint64_t> counts = RequestsPerWorker(client.get());
  ASSERT_EQ(counts.size(), 2u);
  EXPECT_EQ(counts[0], 4u);  // 3 frames each, and its stats request
  EXPECT_EQ(counts[1], 4u);
}

// A map roll-out in progress: one worker serves the map, the other not yet. No request for
// it fails (the worker without it replies UNAVAILABLE, which the client retries, and the
// broker hands the retry to the other worker); a map no worker serves still fails, by name.
TEST(FleetTest, AWorkerWithoutTheMapIsNotAFailedRequest) {
  auto broker = StartBroker();
  ASSERT_NE(broker, nullptr);
  test::TestServer with = StartWorker(*broker);
  ASSERT_NE(with.server, nullptr);
  const std::filesystem::path empty =
      std::filesystem::path(::testing::TempDir()) / "sceneloc_fleet_no_maps";
  std::filesystem::create_directories(empty);
  ServerOptions options = test::TestServerOptions();
  options.connect = broker->backend();
  options.threads = 1;
  options.maps_dir = empty.string();
  test::TestServer without = test::StartTestServerOnDir(options);
  ASSERT_NE(without.server, nullptr);
  auto client = ClientOf(*broker);
  for (int i = 0; i < 6; ++i) {
    auto answer = client->Localise(kTestMapName, test::TourFeatures(i));
    ASSERT_TRUE(answer.ok()) << "request " << i << ": " << answer.status().ToString();
    EXPECT_EQ(answer->locations(0).index(), i);
  }
  // A map no worker serves: a clear NOT_FOUND once the retries are spent, not a timeout.
  const auto start = std::chrono::steady_clock::now();
  auto missing = client->Localise("nowhere", test::TourFeatures(0));
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), StatusCode::kNotFound);
  EXPECT_NE(missing.status().message().find("'nowhere'"), std::string::npos)
      << missing.status().message();
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(2 * test::kTimeScale));
}

// A request of a newer protocol is refused by name, and a worker of another protocol
// version behind the broker gets the client a clear error rather than a misread reply.
TEST(FleetTest, AnotherProtocolVersionIsAClearError) {
  test::TestServer direct = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(direct.server, nullptr);
  auto raw = zmq::context_t();
  zmq::socket_t dealer(raw, zmq::socket_type::dealer);
  dealer.set(zmq::sockopt::rcvtimeo, 5000 * test::kTimeScale);
  dealer.connect(direct.endpoint);
  v1::Request newer;
  newer.set_request_id(7);
  newer.set_protocol(kProtocolVersion + 1);
  newer.mutable_stats();
  dealer.send(zmq::message_t(), zmq::send_flags::sndmore);
  dealer.send(zmq::buffer(newer.SerializeAsString()), zmq::send_flags::none);
  zmq::message_t empty, body;
  ASSERT_TRUE(dealer.recv(empty));
  ASSERT_TRUE(dealer.recv(body));
  v1::Reply refused;
  ASSERT_TRUE(refused.ParseFromArray(body.data(), static_cast<int>(body.size())));
  EXPECT_EQ(refused.status(), v1::UNIMPLEMENTED);
  EXPECT_EQ(refused.protocol(), kProtocolVersion);
  EXPECT_NE(refused.error().find("protocol 2"), std::string::npos) << refused.error();

  // A "worker" of protocol 2 (a raw DEALER on the backend) answering every request.
  auto broker = StartBroker();
  ASSERT_NE(broker, nullptr);
  zmq::socket_t worker(raw, zmq::socket_type::dealer);
  worker.connect(broker->backend());
  std::atomic<bool> stop{false};
  std::thread answer([&] {
    worker.set(zmq::sockopt::rcvtimeo, 50);
    while (!stop) {
      std::vector<zmq::message_t> frames;
      zmq::message_t frame;
      if (!worker.recv(frame)) continue;
      frames.push_back(std::move(frame));
      while (frames.back().more() && worker.recv(frame)) frames.push_back(std::move(frame));
      v1::Request request;
      request.ParseFromArray(frames.back().data(), static_cast<int>(frames.back().size()));
      v1::Reply reply;
      reply.set_request_id(request.request_id());
      reply.set_protocol(2);
      frames.back() = zmq::message_t(reply.SerializeAsString());
      for (size_t i = 0; i < frames.size(); ++i) {
        worker.send(frames[i],
                    i + 1 < frames.size() ? zmq::send_flags::sndmore : zmq::send_flags::none);
      }
    }
  });
  auto client = ClientOf(*broker);
  auto stats = client->Stats();
  stop = true;
  answer.join();
  ASSERT_FALSE(stats.ok());
  EXPECT_EQ(stats.status().code(), StatusCode::kUnimplemented);
  EXPECT_NE(stats.status().message().find("protocol 2; this client speaks 1"), std::string::npos)
      << stats.status().message();
}

// Two groups, each a broker with a worker serving its own map, and a routes file: one
// client (Client::Connect("routes:FILE")) reaches both maps, lists both, and is told by name
// when the routes place a map nowhere.
TEST(FleetTest, GroupsOfMapsThroughARoutesFile) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(::testing::TempDir()) / "sceneloc_fleet_groups";
  fs::remove_all(dir);
  fs::create_directories(dir / "group1");
  fs::create_directories(dir / "group2");
  fs::copy_file(test::TestMapPath(), dir / "group1" / "first.scnl");
  fs::copy_file(test::TestMapPath(), dir / "group2" / "second.scnl");
  std::vector<std::unique_ptr<Broker>> brokers;
  std::vector<test::TestServer> workers;
  for (const char* group : {"group1", "group2"}) {
    brokers.push_back(StartBroker());
    ASSERT_NE(brokers.back(), nullptr);
    ServerOptions options = test::TestServerOptions();
    options.connect = brokers.back()->backend();
    options.threads = 1;
    options.maps_dir = (dir / group).string();
    workers.push_back(test::StartTestServerOnDir(options));
    ASSERT_NE(workers.back().server, nullptr);
  }
  const std::string routes = (dir / "routes.yaml").string();
  std::ofstream(routes) << "maps:\n  first: " << brokers[0]->frontend()
                        << "\n  second: " << brokers[1]->frontend() << "\n";
  auto client = Client::Connect(std::string(kRoutesPrefix) + routes);
  ASSERT_TRUE(client.ok()) << client.status().ToString();
  for (const char* map : {"first", "second"}) {
    auto answer = (*client)->Localise(map, test::TourFeatures(4));
    ASSERT_TRUE(answer.ok()) << map << ": " << answer.status().ToString();
    EXPECT_EQ(answer->locations(0).index(), 4);
    EXPECT_EQ(answer->map().name(), map);
  }
  auto listed = (*client)->ListMaps();
  ASSERT_TRUE(listed.ok()) << listed.status().ToString();
  ASSERT_EQ(listed->maps_size(), 2);
  auto nowhere = (*client)->Localise("third", test::TourFeatures(4));
  EXPECT_EQ(nowhere.status().code(), StatusCode::kNotFound);
  EXPECT_NE(nowhere.status().message().find("routes.yaml"), std::string::npos)
      << nowhere.status().message();

  // A broker's client that cannot be made (here: key files that do not exist) fails the
  // call with its reason and leaves the routed client usable.
  ClientOptions keyed;
  keyed.key_file = (dir / "missing.key").string();
  keyed.server_key_file = (dir / "missing.pub").string();
  auto unkeyed = Client::Connect(std::string(kRoutesPrefix) + routes, keyed);
  ASSERT_TRUE(unkeyed.ok()) << unkeyed.status().ToString();
  const Status no_key = (*unkeyed)->Localise("first", test::TourFeatures(4)).status();
  EXPECT_FALSE(no_key.ok());
  EXPECT_NE(no_key.message().find("missing.key"), std::string::npos) << no_key.message();
  EXPECT_EQ((*unkeyed)->overload_retries(), 0);

  // Routes files that cannot work are refused when connecting, naming the file.
  std::ofstream(routes) << "mapz:\n  first: tcp://127.0.0.1:1\n";
  const Status bad = Client::Connect(std::string(kRoutesPrefix) + routes).status();
  EXPECT_EQ(bad.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(bad.message().find("unknown key 'mapz'"), std::string::npos) << bad.message();
  EXPECT_EQ(
      Client::Connect(std::string(kRoutesPrefix) + (dir / "none.yaml").string()).status().code(),
      StatusCode::kNotFound);
  fs::remove_all(dir);
}

TEST(FleetTest, BadSettingsAreRefusedWithTheirName) {
  BrokerOptions same;
  same.frontend = same.backend = "tcp://127.0.0.1:5999";
  EXPECT_EQ(Broker::Start(same).status().code(), StatusCode::kInvalidArgument);
  BrokerOptions bad;
  bad.frontend = "tcp://127.0.0.1:*";
  bad.backend = "nonsense";
  const Status status = Broker::Start(bad).status();
  EXPECT_EQ(status.code(), StatusCode::kIoError);
  EXPECT_NE(status.message().find("nonsense"), std::string::npos) << status.message();

  ServerOptions worker = test::TestServerOptions();
  worker.connect = "tcp://127.0.0.1:5998";
  worker.auth.enabled = true;
  worker.auth.server_key = "x.key";
  worker.auth.clients = "clients.yaml";
  const Status refused = worker.Validate();
  EXPECT_EQ(refused.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(refused.message().find("server.connect"), std::string::npos) << refused.message();
}

}  // namespace
}  // namespace sceneloc
