// The sceneloc command as a user runs it, against a real in-process server.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

struct RunResult {
  int status = -1;
  std::string output;  // stdout and stderr
};

RunResult RunBinary(const std::string& binary, const std::string& args) {
  RunResult run;
  FILE* pipe = popen((binary + " " + args + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return run;
  char buffer[4096];
  size_t n = 0;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) run.output.append(buffer, n);
  const int status = pclose(pipe);
  run.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

RunResult Sceneloc(const std::string& args) { return RunBinary(SCENELOC_BIN, args); }

class ScenelocCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = test::StartTestServer(test::TestServerOptions());
    ASSERT_NE(server_.server, nullptr);
    dir_ = fs::path(::testing::TempDir()) / ("sceneloc_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    for (int i : {0, 4, 8}) {
      std::ofstream(Image(i), std::ios::binary) << test::TourJpegs()[static_cast<size_t>(i)];
    }
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Image(int i) const { return (dir_ / ("q" + std::to_string(i) + ".jpg")).string(); }
  // A folder "queries" holding every tour JPEG, in tour order; returns it.
  fs::path WriteTourQueries() const {
    const fs::path queries = dir_ / "queries";
    fs::create_directories(queries);
    for (size_t i = 0; i < test::TourJpegs().size(); ++i) {
      std::ofstream(queries / ("Image" + std::to_string(100 + i) + ".jpg"), std::ios::binary)
          << test::TourJpegs()[i];
    }
    return queries;
  }

  test::TestServer server_;
  fs::path dir_;
};

// localise prints one answer line per image, the right location, and exits 0.
TEST_F(ScenelocCliTest, LocalisePrintsOneLinePerImage) {
  const RunResult run = Sceneloc("localise --server " + server_.endpoint + " --map synthetic " +
                                 Image(0) + " " + Image(4) + " " + Image(8));
  EXPECT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("q0.jpg\t0\tImage000.jpg"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("q4.jpg\t4\tImage004.jpg"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("q8.jpg\t8\tImage008.jpg"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("synthetic@1"), std::string::npos) << run.output;
}

// An error reply (unknown map) is printed and makes the exit status 1.
TEST_F(ScenelocCliTest, ErrorReplyExitsOne) {
  const RunResult run =
      Sceneloc("localise --server " + server_.endpoint + " --map nowhere " + Image(0));
  EXPECT_EQ(run.status, 1) << run.output;
  EXPECT_NE(run.output.find("NOT_FOUND"), std::string::npos) << run.output;
}

// extract writes a feature set on the client, in the map's frame (--map-file) or in a frame
// of its own (--working-size), its descriptors uint8 unless --float32 asks for them exact;
// localise --features sends it (float32 and uint8) and gets the right location.
TEST_F(ScenelocCliTest, ExtractThenLocaliseFeatures) {
  const std::string f32 = (dir_ / "q4.f32.pb").string(), u8 = (dir_ / "q4.u8.pb").string(),
                    plain = (dir_ / "q4.pb").string();
  RunResult run = Sceneloc("extract " + Image(4) + " --out " + f32 + " --map-file " +
                           test::TestMapPath() + " --float32");
  ASSERT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("(640x360)"), std::string::npos) << run.output;
  run = Sceneloc("extract " + Image(4) + " --out " + u8 + " --working-size 480 --uint8");
  ASSERT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("(480x270)"), std::string::npos) << run.output;
  EXPECT_LT(fs::file_size(u8) * 2, fs::file_size(f32));
  run = Sceneloc("extract " + Image(4) + " --out " + plain + " --map-file " + test::TestMapPath());
  ASSERT_EQ(run.status, 0) << run.output;
  EXPECT_LT(fs::file_size(plain) * 2, fs::file_size(f32));  // uint8 by default
  run = Sceneloc("extract " + Image(4) + " --out " + plain + " --uint8 --float32");
  EXPECT_NE(run.status, 0) << run.output;  // one or the other
  EXPECT_NE(run.output.find("excludes"), std::string::npos) << run.output;
  run = Sceneloc("bench --server " + server_.endpoint + " --map synthetic --features " +
                 "--float32 --uint8 " + dir_.string());  // bench --features: the same pair
  EXPECT_NE(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("excludes"), std::string::npos) << run.output;
  run = Sceneloc("localise --features --server " + server_.endpoint + " --map synthetic " + f32 +
                 " " + u8);
  EXPECT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("f32.pb\t4\t"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("u8.pb\t4\t"), std::string::npos) << run.output;
  // The thin client (no OpenCV linked) sends the same file.
  run = RunBinary(SCENELOC_THIN_CLIENT_BIN, server_.endpoint + " synthetic " + f32);
  EXPECT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("location 4 (Image004.jpg)"), std::string::npos) << run.output;
  run = RunBinary(SCENELOC_THIN_CLIENT_BIN, server_.endpoint + " synthetic " + Image(4));  // a JPEG
  EXPECT_EQ(run.status, 1) << run.output;
  EXPECT_NE(run.output.find("cannot read a feature set"), std::string::npos) << run.output;
}

// maps lists the served map with its generation and the version that trained it (the
// test map is trained by this tree, so the client's own --version).
TEST_F(ScenelocCliTest, MapsListsGenerations) {
  const RunResult run = Sceneloc("maps --server " + server_.endpoint);
  EXPECT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("synthetic\tgeneration 1"), std::string::npos) << run.output;
  RunResult version = Sceneloc("--version");
  ASSERT_EQ(version.status, 0) << version.output;
  ASSERT_EQ(version.output.rfind("0.", 0), 0u) << version.output;
  version.output.pop_back();  // the newline
  EXPECT_NE(run.output.find("\ttrained by " + version.output + "\n"), std::string::npos)
      << run.output;
}

// bench runs 2 clients for about a second against the real server and writes the JSON a
// user relies on: requests answered, no errors, latency percentiles, the map generation.
TEST_F(ScenelocCliTest, BenchWritesJsonSummary) {
  const fs::path queries = WriteTourQueries();
  const std::string json_path = (dir_ / "bench.json").string();
  const RunResult run = Sceneloc("bench --server " + server_.endpoint +
                                 " --map synthetic --clients 2 --duration 1 --json " + json_path +
                                 " " + queries.string());
  EXPECT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("throughput"), std::string::npos) << run.output;
  std::ifstream in(json_path);
  ASSERT_TRUE(in) << run.output;
  const nlohmann::json json = nlohmann::json::parse(in);
  EXPECT_GT(json["requests"].get<int64_t>(), 0);
  EXPECT_EQ(json["ok"], json["requests"]);
  EXPECT_GT(json["throughput_rps"].get<double>(), 0);
  EXPECT_TRUE(json["errors"].empty()) << json.dump();
  const nlohmann::json& latency = json["latency_ms"];
  EXPECT_GT(latency["p50"].get<double>(), 0);
  EXPECT_LE(latency["p50"].get<double>(), latency["p90"].get<double>());
  EXPECT_LE(latency["p90"].get<double>(), latency["p99"].get<double>());
  EXPECT_EQ(json["map_versions"], nlohmann::json::array({1})) << json.dump();
  EXPECT_EQ(json["mode"], "jpeg");
  // Bounded: it stops by itself shortly after the duration.
  EXPECT_LT(json["elapsed_s"].get<double>(), 5.0 * test::kTimeScale);
}

// bench --features extracts on the client (the map's settings and frame) and sends
// feature sets, which the server answers without errors.
TEST_F(ScenelocCliTest, BenchSendsFeatureSets) {
  const std::string json_path = (dir_ / "bench.json").string();
  const fs::path queries = dir_ / "queries";
  fs::create_directories(queries);
  fs::copy_file(Image(4), queries / "q4.jpg");
  const RunResult run =
      Sceneloc("bench --server " + server_.endpoint +
               " --map synthetic --clients 2 --duration 0.5 --features "
               "--map-file " +
               test::TestMapPath() + " --json " + json_path + " " + queries.string());
  EXPECT_EQ(run.status, 0) << run.output;
  std::ifstream in(json_path);
  ASSERT_TRUE(in) << run.output;
  const nlohmann::json json = nlohmann::json::parse(in);
  EXPECT_GT(json["requests"].get<int64_t>(), 0);
  EXPECT_TRUE(json["errors"].empty()) << json.dump();
  EXPECT_EQ(json["mode"], "features");
}

// An unknown map: every request fails, bench counts them by status name and exits 1.
TEST_F(ScenelocCliTest, BenchCountsErrorsByKind) {
  const std::string json_path = (dir_ / "bench.json").string();
  const fs::path queries = dir_ / "queries";
  fs::create_directories(queries);
  fs::copy_file(Image(0), queries / "q0.jpg");
  const RunResult run = Sceneloc("bench --server " + server_.endpoint +
                                 " --map nowhere --clients 1 --duration 0.3 --json " + json_path +
                                 " " + queries.string());
  EXPECT_EQ(run.status, 1) << run.output;
  std::ifstream in(json_path);
  ASSERT_TRUE(in) << run.output;
  const nlohmann::json json = nlohmann::json::parse(in);
  EXPECT_GT(json["requests"].get<int64_t>(), 0);
  EXPECT_EQ(json["errors"]["NOT_FOUND"], json["requests"]) << json.dump();
  EXPECT_EQ(json["ok"], 0);
  EXPECT_TRUE(json["map_versions"].empty());
}

// localise --session sends the images in order as one session: every answer line is followed
// by the session's (its frame number, location, decision), the first marked a new session;
// --reset-session starts it again.
TEST_F(ScenelocCliTest, LocaliseSession) {
  const std::string args =
      "localise --server " + server_.endpoint + " --map synthetic --session robot-1 ";
  const RunResult run = Sceneloc(args + Image(0) + " " + Image(4) + " " + Image(8));
  EXPECT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("q0.jpg\tsession robot-1 frame 1\t"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("(new session)"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("q8.jpg\tsession robot-1 frame 3\t8\tImage008.jpg"), std::string::npos)
      << run.output;
  const RunResult more = Sceneloc(args + Image(8));
  EXPECT_NE(more.output.find("session robot-1 frame 4\t"), std::string::npos) << more.output;
  const RunResult reset = Sceneloc(args + "--reset-session " + Image(0) + " " + Image(4));
  EXPECT_NE(reset.output.find("q0.jpg\tsession robot-1 frame 1\t"), std::string::npos)
      << reset.output;
  EXPECT_NE(reset.output.find("(session reset)"), std::string::npos) << reset.output;
  EXPECT_NE(reset.output.find("q4.jpg\tsession robot-1 frame 2\t"), std::string::npos)
      << reset.output;
  const RunResult bad = Sceneloc("localise --server " + server_.endpoint +
                                 " --map synthetic --session \"$(printf 'a\\tb')\" " + Image(0));
  EXPECT_EQ(bad.status, 1) << bad.output;
  EXPECT_NE(bad.output.find("INVALID_ARGUMENT: session name"), std::string::npos) << bad.output;
}

// bench --sessions: each client thread is one session through the folder; the summary counts
// the session answers that were LOCALISED.
TEST_F(ScenelocCliTest, BenchSessions) {
  const fs::path queries = WriteTourQueries();
  const std::string json_path = (dir_ / "bench.json").string();
  const RunResult run = Sceneloc("bench --server " + server_.endpoint +
                                 " --map synthetic --clients 2 --duration 1 --sessions --json " +
                                 json_path + " " + queries.string());
  EXPECT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("sessions    one per client"), std::string::npos) << run.output;
  std::ifstream in(json_path);
  ASSERT_TRUE(in) << run.output;
  const nlohmann::json json = nlohmann::json::parse(in);
  EXPECT_EQ(json["sessions"], true);
  EXPECT_TRUE(json["errors"].empty()) << json.dump();
  EXPECT_GT(json["session_localised"].get<int64_t>(), 0) << json.dump();
  EXPECT_LE(json["session_localised"].get<int64_t>(), json["ok"].get<int64_t>());
}

}  // namespace
}  // namespace sceneloc
