// The sceneloc command as a user runs it, against a real in-process server.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

struct RunResult {
  int status = -1;
  std::string output;  // stdout and stderr
};

RunResult Sceneloc(const std::string& args) {
  RunResult run;
  FILE* pipe = popen((std::string(SCENELOC_BIN) + " " + args + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return run;
  char buffer[4096];
  size_t n = 0;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) run.output.append(buffer, n);
  const int status = pclose(pipe);
  run.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

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

// extract writes a feature set on the client; localise --features sends it (float32 and
// uint8) and gets the right location.
TEST_F(ScenelocCliTest, ExtractThenLocaliseFeatures) {
  const std::string f32 = (dir_ / "q4.f32.pb").string(), u8 = (dir_ / "q4.u8.pb").string();
  RunResult run = Sceneloc("extract " + Image(4) + " --out " + f32 + " --image-scale 1");
  ASSERT_EQ(run.status, 0) << run.output;
  run = Sceneloc("extract " + Image(4) + " --out " + u8 + " --image-scale 1 --uint8");
  ASSERT_EQ(run.status, 0) << run.output;
  EXPECT_LT(fs::file_size(u8) * 2, fs::file_size(f32));
  run = Sceneloc("localise --features --server " + server_.endpoint + " --map synthetic " + f32 +
                 " " + u8);
  EXPECT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("f32.pb\t4\t"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("u8.pb\t4\t"), std::string::npos) << run.output;
}

// maps lists the served map with its generation.
TEST_F(ScenelocCliTest, MapsListsGenerations) {
  const RunResult run = Sceneloc("maps --server " + server_.endpoint);
  EXPECT_EQ(run.status, 0) << run.output;
  EXPECT_NE(run.output.find("synthetic\tgeneration 1"), std::string::npos) << run.output;
}

}  // namespace
}  // namespace sceneloc
