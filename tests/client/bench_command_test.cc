// `sceneloc bench` run in-process (client/bench_command.h): bad arguments and unreadable
// inputs exit 2 with a message before any request; against a real server on
// tcp://127.0.0.1:* it exits 0 when every request was answered, 1 when any failed, and
// writes the documented JSON.
#include "client/bench_command.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/server/server_test_support.h"
#include "tests/support/scratch_dir.h"

namespace sceneloc {
namespace {

struct BenchRun {
  int status = -1;
  std::string out, err;
};

BenchRun RunCaptured(const BenchArgs& args) {
  BenchRun run;
  ::testing::internal::CaptureStdout();
  ::testing::internal::CaptureStderr();
  run.status = RunBench(args);
  run.err = ::testing::internal::GetCapturedStderr();
  run.out = ::testing::internal::GetCapturedStdout();
  return run;
}

// A folder of three tour JPEGs of the test map and arguments for a short run (against no
// server until a test starts one).
class BenchCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (int i : {1, 5, 9}) {
      test::WriteFileBytes(images_.File("q" + std::to_string(i) + ".jpg"),
                           test::TourJpegs()[static_cast<size_t>(i)]);
    }
    args_.endpoint = "ipc://" + images_.File("no_server");  // the refusals never dial it
    args_.map = test::kTestMapName;
    args_.image_dir = images_.path().string();
    args_.duration_s = 0.3;
    args_.timeout_ms = 5000 * test::kTimeScale;
  }
  // Runs with one change to the arguments; expects exit 2 and the message on stderr.
  void ExpectRefused(const std::function<void(BenchArgs*)>& change, const std::string& message) {
    BenchArgs args = args_;
    change(&args);
    const BenchRun run = RunCaptured(args);
    EXPECT_EQ(run.status, 2) << run.out << run.err;
    EXPECT_EQ(run.err.rfind("sceneloc bench: ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find(message), std::string::npos) << run.err;
  }
  // Starts a real server for the test and points the arguments at it.
  void StartServer() {
    server_ = test::StartTestServer(test::TestServerOptions());
    ASSERT_NE(server_.server, nullptr);
    args_.endpoint = server_.endpoint;
  }
  nlohmann::json ReadJson() const {
    std::ifstream in(args_.json_out);
    return nlohmann::json::parse(in);
  }

  const test::ScratchDir images_{"bench"};
  const test::ScratchDir out_{"bench_out"};
  BenchArgs args_;
  test::TestServer server_;
};

// Each invalid setting is refused by name, before the folder is read (it does not exist).
TEST_F(BenchCommandTest, InvalidArgumentsExitTwo) {
  args_.image_dir = images_.File("absent");
  ExpectRefused([](BenchArgs* a) { a->endpoint.clear(); }, "no server endpoint");
  ExpectRefused([](BenchArgs* a) { a->map.clear(); }, "no map name");
  ExpectRefused([](BenchArgs* a) { a->clients = 0; }, "clients must be >= 1");
  ExpectRefused([](BenchArgs* a) { a->duration_s = 0; }, "duration must be > 0 seconds");
  ExpectRefused([](BenchArgs* a) { a->duration_s = std::nan(""); }, "duration must be > 0");
  ExpectRefused([](BenchArgs* a) { a->timeout_ms = 0; }, "timeout_ms must be >= 1");
  ExpectRefused([](BenchArgs* a) { a->retries = -1; }, "retries must be >= 0");
  ExpectRefused([](BenchArgs* a) { a->top_k = -1; }, "top_k must be >= 0");
}

// A missing or empty folder, a map file that cannot be read for --features, an image that
// cannot be decoded, or an endpoint that is not one: exit 2 naming what is wrong.
TEST_F(BenchCommandTest, UnreadableInputsExitTwo) {
  const std::string absent = images_.File("absent");
  ExpectRefused([&](BenchArgs* a) { a->image_dir = absent; }, "'" + absent + "' does not exist");
  const test::ScratchDir empty("bench_empty");
  ExpectRefused([&](BenchArgs* a) { a->image_dir = empty.path().string(); }, "holds no image file");
  const std::string no_map = images_.File("absent.scnl");
  ExpectRefused(
      [&](BenchArgs* a) {
        a->features = true;
        a->map_file = no_map;
      },
      no_map);
  ExpectRefused([](BenchArgs* a) { a->endpoint = "not-an-endpoint"; },
                "cannot connect to 'not-an-endpoint'");
  test::WriteFileBytes(images_.File("q9.jpg"), "not a jpeg");
  ExpectRefused(
      [](BenchArgs* a) {
        a->features = true;
        a->map_file = test::TestMapPath();
      },
      images_.File("q9.jpg") + ": image bytes are not a decodable JPEG or PNG");
}

// Against the real server: every request answered, exit 0, and the JSON holds the run as
// documented (percentiles in order, no error, the map version and its checksum).
TEST_F(BenchCommandTest, WritesTheDocumentedJson) {
  StartServer();
  args_.json_out = out_.File("bench.json");
  const BenchRun run = RunCaptured(args_);
  ASSERT_EQ(run.status, 0) << run.out << run.err;
  EXPECT_NE(run.out.find("bench: " + server_.endpoint + ", 1 client(s)"), std::string::npos)
      << run.out;
  const nlohmann::json j = ReadJson();
  EXPECT_GT(j["requests"].get<int>(), 0);
  EXPECT_EQ(j["ok"], j["requests"]);
  EXPECT_EQ(j["clients"], 1);
  EXPECT_EQ(j["mode"], "jpeg");
  EXPECT_EQ(j["map"], test::kTestMapName);
  EXPECT_TRUE(j["errors"].empty());
  EXPECT_GT(j["throughput_rps"].get<double>(), 0);
  const nlohmann::json& latency = j["latency_ms"];
  EXPECT_LE(latency["p50"].get<double>(), latency["p90"].get<double>());
  EXPECT_LE(latency["p90"].get<double>(), latency["p99"].get<double>());
  EXPECT_LE(latency["p99"].get<double>(), latency["max"].get<double>());
  EXPECT_LE(j["server_ms"]["p50"].get<double>(), latency["max"].get<double>());
  // Outside the server, request by request: a real loopback round trip takes some time, and
  // never more than the whole (each request's part is at most its latency, so every
  // quantile is too).
  const nlohmann::json& outside = j["outside_ms"];
  EXPECT_GT(outside["p50"].get<double>(), 0);
  EXPECT_LE(outside["p50"].get<double>(), latency["p50"].get<double>());
  EXPECT_LE(outside["p99"].get<double>(), latency["p99"].get<double>());
  EXPECT_NE(run.out.find("outside ms  p50 "), std::string::npos) << run.out;
  // The server's stages, each no longer than the whole: JPEGs are decoded and extracted.
  const nlohmann::json& stages = j["server_stage_ms"];
  for (const char* stage : {"queue", "decode", "extract", "descriptor", "neighbourhood",
                            "likelihood", "holistic", "verify"}) {
    ASSERT_TRUE(stages.contains(stage)) << stage << " " << j.dump();
    EXPECT_LE(stages[stage]["p50"].get<double>(), stages[stage]["max"].get<double>()) << stage;
    EXPECT_LE(stages[stage]["max"].get<double>(), j["server_ms"]["max"].get<double>()) << stage;
  }
  EXPECT_GT(stages["decode"]["p50"].get<double>(), 0);
  EXPECT_GT(stages["extract"]["p50"].get<double>(), 0);
  EXPECT_NE(run.out.find("server p50   queue "), std::string::npos) << run.out;
  ASSERT_EQ(j["map_versions"].size(), 1u);
  const std::string generation = std::to_string(j["map_versions"][0].get<uint64_t>());
  ASSERT_TRUE(j["map_checksums"].contains(generation)) << j.dump();
  EXPECT_EQ(j["map_checksums"][generation].get<std::string>().size(), 8u);
}

// Feature sets extracted on the client with the map's settings, sent as uint8 (the
// default) and as float32.
TEST_F(BenchCommandTest, SendsFeatureSets) {
  StartServer();
  args_.features = true;
  args_.map_file = test::TestMapPath();
  args_.json_out = out_.File("bench.json");
  for (const bool uint8 : {true, false}) {
    args_.uint8 = uint8;
    const BenchRun run = RunCaptured(args_);
    ASSERT_EQ(run.status, 0) << run.out << run.err;
    const nlohmann::json j = ReadJson();
    EXPECT_EQ(j["mode"], "features");
    EXPECT_EQ(j["descriptors"], uint8 ? "uint8" : "float32");
    EXPECT_EQ(j["ok"], j["requests"]);
  }
}

// A map the server does not have: every request fails, counted by status name; exit 1.
// A JSON file that cannot be written: exit 2 after the run.
TEST_F(BenchCommandTest, FailedRequestsAndUnwritableJson) {
  StartServer();
  args_.map = "no_such_map";
  args_.json_out = out_.File("bench.json");
  const BenchRun failed = RunCaptured(args_);
  EXPECT_EQ(failed.status, 1) << failed.out << failed.err;
  const nlohmann::json j = ReadJson();
  EXPECT_EQ(j["ok"], 0);
  EXPECT_EQ(j["errors"]["NOT_FOUND"], j["requests"]);

  args_.map = test::kTestMapName;
  const std::string unwritable = out_.File("absent/bench.json");
  ExpectRefused([&](BenchArgs* a) { a->json_out = unwritable; },
                "cannot write '" + unwritable + "'");
}

}  // namespace
}  // namespace sceneloc
