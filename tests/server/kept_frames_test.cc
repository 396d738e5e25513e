// Frames kept where the map failed, end to end (docs/experiences.md "Frames where the map
// failed"): a real server on loopback with keep_frames set, a robot's session that walks the
// route and then a street the map does not hold, `sceneloc frames` listing and fetching what
// was kept, and sceneloc-train --extend adding the fetched folder to the map as new ground.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "client/client.h"
#include "client/frames_command.h"
#include "common/map/map_io.h"
#include "common/synthetic/tour_generator.h"
#include "tests/server/server_call_support.h"
#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;
using test::kTestMapName;
using test::kTestTourLocations;

class KeptFramesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // One folder per test: ctest runs the tests of this file in parallel processes.
    dir_ = fs::path(::testing::TempDir()) /
           ("kept_frames_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    options_ = test::TestServerOptions();
    options_.keep_frames.dir = (dir_ / "kept").string();
    options_.keep_frames.min_unknown_frames = 3;
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
  ServerOptions options_;
};

// Another street's frames, rendered as the test tour's are.
std::vector<std::string> StreetJpegs() {
  TourOptions street;
  street.num_locations = kTestTourLocations;
  street.seed = 7;
  auto jpegs = RenderTourJpegs(street, kTrainingPass);
  EXPECT_TRUE(jpegs.ok()) << jpegs.status().ToString();
  return jpegs.ok() ? *jpegs : std::vector<std::string>();
}

TEST_F(KeptFramesTest, KeepsWhereTheMapFailedAndTheFolderExtendsTheMap) {
  test::TestServer server = test::StartTestServer(options_);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  auto robot = test::MustConnect(server.endpoint);
  LocaliseOptions session;
  session.session = "rover/7";  // not a file name: the run's name makes it one
  int last_localised = -1;
  for (int i = 0; i < 6; ++i) {
    auto reply = robot->Localise(kTestMapName, test::TourJpegs()[static_cast<size_t>(i)], session);
    ASSERT_TRUE(reply.ok()) << reply.status().ToString();
    if (reply->session().decision() == v1::LOCALISED) last_localised = reply->session().location();
  }
  ASSERT_GE(last_localised, 3) << "the route's frames never localised the session";
  const std::vector<std::string> street = StreetJpegs();
  int streak_start = -1;  // the first street frame of the UNKNOWN streak it ends in
  for (size_t i = 0; i < street.size(); ++i) {
    auto reply = robot->Localise(kTestMapName, street[i], session);
    ASSERT_TRUE(reply.ok()) << reply.status().ToString();
    if (reply->session().decision() == v1::LOCALISED) {
      streak_start = -1;
    } else if (streak_start < 0) {
      streak_start = static_cast<int>(i);
    }
  }
  ASSERT_GE(streak_start, 0);
  const auto unknown = static_cast<uint32_t>(street.size()) - static_cast<uint32_t>(streak_start);
  // Back on the route: the run ends.
  for (int i = 0; i < 3; ++i) {
    ASSERT_TRUE(
        robot->Localise(kTestMapName, test::TourJpegs()[static_cast<size_t>(i)], session).ok());
  }
  ASSERT_GE(unknown, 8u) << "the other street should not be recognised";

  v1::KeptFramesRequest list;
  v1::KeptFramesReply listed;
  // Writes are queued on the keeper's thread: the run shows once they are done.
  for (int attempt = 0; attempt < 200; ++attempt) {
    auto reply = robot->KeptFrames(list);
    ASSERT_TRUE(reply.ok()) << reply.status().ToString();
    listed = *reply;
    if (listed.runs_size() == 1 && listed.runs(0).frames() >= unknown) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  ASSERT_EQ(listed.runs_size(), 1) << listed.DebugString();
  const v1::KeptRun& run = listed.runs(0);
  EXPECT_EQ(run.map(), kTestMapName);
  EXPECT_EQ(run.session(), "rover/7");
  EXPECT_NE(run.run().find("rover_7"), std::string::npos) << run.run();
  // The streak from its first frame (and a route frame or two before the session recovers).
  EXPECT_GE(run.frames(), unknown);
  EXPECT_LE(run.frames(), unknown + 3);
  EXPECT_EQ(run.anchor_place(), last_localised);
  EXPECT_GT(listed.bytes_used(), 0u);
  EXPECT_EQ(listed.quota_bytes(), static_cast<uint64_t>(options_.keep_frames.quota_bytes));

  // `sceneloc frames fetch`: every run of the map, byte for byte what the robot sent.
  FramesArgs fetch{"fetch", kTestMapName, "", (dir_ / "fetched").string()};
  ASSERT_EQ(RunFrames(robot.get(), fetch), 0);
  const fs::path walk = dir_ / "fetched" / run.run();
  ASSERT_TRUE(fs::exists(dir_ / "fetched" / (run.run() + ".yaml")));
  EXPECT_EQ(test::ReadFile((walk / "000000.jpg").string()),
            street[static_cast<size_t>(streak_start)]);

  // The fetched folder is a walk: new ground for the map.
  const std::string extended = (dir_ / "extended.scnl").string();
  const std::string command = std::string(SCENELOC_TRAIN_BIN) + " --extend '" +
                              test::TestMapPath() + "' --tour '" + walk.string() + "' --out '" +
                              extended + "' --new-ground > '" + (dir_ / "extend.log").string() +
                              "' 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << test::ReadFile((dir_ / "extend.log").string());
  auto map = LoadMap(extended);
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  EXPECT_GT(map->num_places(), kTestTourLocations);
  ASSERT_EQ(map->experiences.size(), 2u);
  EXPECT_EQ(map->experiences[1].name, run.run());

  // `sceneloc frames delete` frees the quota.
  FramesArgs remove{"delete", kTestMapName, run.run(), ""};
  ASSERT_EQ(RunFrames(robot.get(), remove), 0);
  auto after = robot->KeptFrames(list);
  ASSERT_TRUE(after.ok()) << after.status().ToString();
  EXPECT_EQ(after->runs_size(), 0);
  EXPECT_EQ(after->bytes_used(), 0u);
  list.set_map(kTestMapName);
  EXPECT_EQ(robot->KeptFrames(list).status().code(), StatusCode::kNotFound);
}

// What a client can get wrong is an error reply, and a server that keeps no frames says how
// to make it keep them.
TEST_F(KeptFramesTest, BadRequestsAreClearErrors) {
  test::TestServer server = test::StartTestServer(options_);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  auto client = test::MustConnect(server.endpoint);
  v1::KeptFramesRequest request;
  request.set_action(v1::KeptFramesRequest::FETCH);
  request.set_map("../etc");
  request.set_run("x");
  EXPECT_EQ(client->KeptFrames(request).status().code(), StatusCode::kInvalidArgument);
  request.set_map(kTestMapName);
  request.set_run("no-such-run");
  const Status missing = client->KeptFrames(request).status();
  EXPECT_EQ(missing.code(), StatusCode::kNotFound) << missing.ToString();
  EXPECT_NE(missing.message().find("no-such-run"), std::string::npos);
  request.set_action(static_cast<v1::KeptFramesRequest::Action>(9));
  EXPECT_EQ(client->KeptFrames(request).status().code(), StatusCode::kInvalidArgument);
  FramesArgs no_out{"fetch", kTestMapName, "", ""};
  EXPECT_EQ(RunFrames(client.get(), no_out), 2);

  options_.keep_frames.dir.clear();
  test::TestServer plain = test::StartTestServer(options_);
  ASSERT_FALSE(::testing::Test::HasFatalFailure());
  const Status off = test::MustConnect(plain.endpoint)->KeptFrames({}).status();
  EXPECT_EQ(off.code(), StatusCode::kFailedPrecondition) << off.ToString();
  EXPECT_NE(off.message().find("--keep-frames"), std::string::npos) << off.message();
}

}  // namespace
}  // namespace sceneloc
