// Robot sessions end to end, through a real server on tcp://127.0.0.1:* serving the map of
// the generated tour: frames of one session are filtered together, sessions do not disturb
// each other, reset and a map reload start one again, the store's bounds (LRU, idle
// timeout) hold, and bad session names are refused while the server keeps serving.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <tuple>

#include "client/client.h"
#include "common/map/crc32.h"
#include "common/map/map_io.h"
#include "common/matching/sequence_filter.h"
#include "proto/wire.h"
#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

using test::kTestMapName;
using test::kTestTourLocations;

// A localise request of session `session` for tour location `i`, carrying `state`.
v1::Request CarriedFrame(int i, const std::string& session, const std::string& state) {
  v1::Request request;
  v1::LocaliseRequest* localise = request.mutable_localise();
  localise->set_map(kTestMapName);
  localise->set_session(session);
  localise->set_session_state(state);
  EncodeFeatureSet(test::TourFeatures(i), DescriptorEncoding::kFloat32,
                   localise->mutable_features());
  return request;
}

// The values of a session's state on the test map with the server's default filter
// settings, once it has seen a frame.
size_t TestStateSize() {
  auto map = LoadMap(test::TestMapPath());
  EXPECT_TRUE(map.ok());
  if (!map.ok()) return 0;
  const SequenceFilter filter(*map, SequenceOptions());
  return SequenceFilter::StateValues(map->num_images(), filter.num_speeds(), filter.num_tracked());
}

class SessionTest : public ::testing::Test {
 protected:
  void Start(const ServerOptions& options) {
    server_ = test::StartTestServerOnDir(options);
    ASSERT_FALSE(HasFatalFailure());
    client_ = Connect();
  }
  void SetUp() override {
    ServerOptions options = test::TestServerOptions();
    options.maps_dir = dir_.path();
    Start(options);
  }

  std::unique_ptr<Client> Connect() const {
    ClientOptions options;
    options.timeout_ms = 20000 * test::kTimeScale;
    options.retries = 0;
    auto client = Client::Connect(server_.endpoint, options);
    EXPECT_TRUE(client.ok());
    return client.ok() ? std::move(client).value() : nullptr;
  }

  // Tour location `i` (its features) as a frame of `session`.
  static StatusOr<v1::LocaliseReply> Frame(Client* client, int i, const std::string& session,
                                           bool reset = false) {
    LocaliseOptions options;
    options.session = session;
    options.reset_session = reset;
    return client->Localise(kTestMapName, test::TourFeatures(i), options);
  }

  test::TempMapsDir dir_{"sessions"};
  test::TestServer server_;
  std::unique_ptr<Client> client_;
};

// A walk along the tour as one session: the frames are counted, the first is NEW and the
// rest CONTINUED, and the session's answers follow the robot, LOCALISED once it has seen a
// few frames. A request without a session has no session answer.
TEST_F(SessionTest, SessionFollowsTheWalk) {
  for (int i = 0; i < kTestTourLocations; ++i) {
    auto reply = Frame(client_.get(), i, "robot-a");
    ASSERT_TRUE(reply.ok()) << reply.status().ToString();
    ASSERT_TRUE(reply->has_session());
    const v1::SessionAnswer& s = reply->session();
    EXPECT_EQ(s.name(), "robot-a");
    EXPECT_EQ(s.frames(), static_cast<uint32_t>(i + 1));
    EXPECT_EQ(s.start(), i == 0 ? v1::NEW : v1::CONTINUED);
    EXPECT_FLOAT_EQ(s.min_confidence(), 0.8f);
    EXPECT_GE(s.probability(), 0.0f);
    EXPECT_LE(s.probability(), s.belief());  // the track's support only lowers the belief
    EXPECT_LE(s.belief() + s.off_map(), 1.0f + 1e-5f);
    EXPECT_GE(s.track_support(), 0.0f);
    EXPECT_LE(s.track_support(), 1.0f);
    // The frames agree with the track: its support is above even odds (not far above: on a
    // tour this short, a frame within a frame's travel of the answer says little).
    if (i >= 1) {
      EXPECT_GT(s.track_support(), 0.5f) << "frame " << i;
    }
    if (i >= 2) {
      EXPECT_LE(std::abs(s.location() - i), 2) << "frame " << i;
      EXPECT_EQ(s.decision(), v1::LOCALISED) << "frame " << i;
    }
    EXPECT_NEAR(s.camera_scale(), 1.0f, 0.05f) << "frame " << i;  // the tour's own camera
  }
  auto alone = client_->Localise(kTestMapName, test::TourFeatures(3));
  ASSERT_TRUE(alone.ok());
  EXPECT_FALSE(alone->has_session());
}

// A robot whose camera sees everything 1.3x larger than the tour's (its keypoints' sizes
// scaled): the session learns the factor from its LOCALISED frames and reports it, 1 until
// it has measured camera_min_frames of them; it carries it in its state from frame to frame.
TEST_F(SessionTest, SessionLearnsTheRobotsCamera) {
  float scale = 0;
  for (int i = 0; i < kTestTourLocations; ++i) {
    FeatureSet features = test::TourFeatures(i);
    for (Keypoint& k : features.keypoints) k.size *= 1.3f;
    LocaliseOptions options;
    options.session = "zoomed";
    auto reply = client_->Localise(kTestMapName, features, options);
    ASSERT_TRUE(reply.ok()) << reply.status().ToString();
    if (i < 2) {
      EXPECT_FLOAT_EQ(reply->session().camera_scale(), 1.0f) << "frame " << i;
    }
    scale = reply->session().camera_scale();
  }
  EXPECT_NEAR(scale, 1.3f, 0.06f);
}

// A session's frame is answered on its own as a frame of that camera: once the session has
// learnt the scale, the single-frame answer is read with it (the reply's camera_scale) and
// is the answer a request stating that camera gets. A frame on its own is read with the
// tour's camera (1) unless its request states one.
TEST_F(SessionTest, TheFramesOwnAnswerIsReadWithTheSessionsCamera) {
  const auto zoomed = [](int i) {
    FeatureSet features = test::TourFeatures(i);
    for (Keypoint& k : features.keypoints) k.size *= 1.3f;
    return features;
  };
  LocaliseOptions in_session;
  in_session.session = "zoomed";
  StatusOr<v1::LocaliseReply> last = InvalidArgument("no frame");
  int changed = 0;  // frames whose ranking the camera changed
  for (int i = 0; i < kTestTourLocations; ++i) {
    last = client_->Localise(kTestMapName, zoomed(i), in_session);
    ASSERT_TRUE(last.ok()) << last.status().ToString();
    EXPECT_FLOAT_EQ(last->camera_scale(), last->session().camera_scale()) << "frame " << i;
    auto alone = client_->Localise(kTestMapName, zoomed(i));
    ASSERT_TRUE(alone.ok());
    std::vector<int> a, b;
    for (const auto& r : last->locations()) a.push_back(r.index());
    for (const auto& r : alone->locations()) b.push_back(r.index());
    changed += a != b || last->confidence() != alone->confidence();
  }
  EXPECT_GT(changed, 0);  // the camera is what changes them
  ASSERT_NEAR(last->camera_scale(), 1.3f, 0.06f);
  const int i = kTestTourLocations - 1;
  auto alone = client_->Localise(kTestMapName, zoomed(i));
  ASSERT_TRUE(alone.ok());
  EXPECT_FLOAT_EQ(alone->camera_scale(), 1.0f);
  LocaliseOptions stated;
  stated.camera_scale = last->camera_scale();
  auto told = client_->Localise(kTestMapName, zoomed(i), stated);
  ASSERT_TRUE(told.ok());
  EXPECT_FLOAT_EQ(told->camera_scale(), last->camera_scale());
  EXPECT_NEAR(told->confidence(), last->confidence(), 1e-3);
  EXPECT_EQ(told->locations(0).index(), last->locations(0).index());
}

// A frame of another shape than the tour's (4:3 against the test tour's 16:9) states no
// camera: it is read halfway between the tour camera's horizontal field of view (1) and its
// vertical one (4/3), in a session too until the session has measured the camera — here
// the tour's own (the keypoints are the tour's), which it then reads with. A stated camera
// is used as stated.
TEST_F(SessionTest, AFrameOfAnotherShapeIsReadWithTheCameraItImplies) {
  const auto taller = [](int i) {
    FeatureSet features = test::TourFeatures(i);
    features.image_height = features.image_width * 3 / 4;
    return features;
  };
  const float halfway = std::sqrt(4.0f / 3.0f);
  auto alone = client_->Localise(kTestMapName, taller(2));
  ASSERT_TRUE(alone.ok()) << alone.status().ToString();
  EXPECT_NEAR(alone->camera_scale(), halfway, 1e-3);
  LocaliseOptions stated;
  stated.camera_scale = 1.0f;
  auto told = client_->Localise(kTestMapName, taller(2), stated);
  ASSERT_TRUE(told.ok());
  EXPECT_FLOAT_EQ(told->camera_scale(), 1.0f);
  LocaliseOptions in_session;
  in_session.session = "four-thirds";
  for (int i = 0; i < kTestTourLocations; ++i) {
    auto reply = client_->Localise(kTestMapName, taller(i), in_session);
    ASSERT_TRUE(reply.ok()) << reply.status().ToString();
    EXPECT_FLOAT_EQ(reply->camera_scale(), reply->session().camera_scale()) << "frame " << i;
    if (i < 2) {  // nothing measured yet
      EXPECT_NEAR(reply->session().camera_scale(), halfway, 1e-3) << "frame " << i;
      EXPECT_NEAR(reply->session().measured_camera_scale(), halfway, 1e-3) << "frame " << i;
    }
    if (i == kTestTourLocations - 1) {
      EXPECT_NEAR(reply->session().camera_scale(), 1.0f, 0.06f);
      EXPECT_EQ(reply->session().decision(), v1::LOCALISED);
    }
  }
}

// A camera the request states is the session's from its first frame; out of [0.25, 4] it is
// refused by name and the server goes on serving.
TEST_F(SessionTest, AStatedCameraIsTheSessions) {
  LocaliseOptions options;
  options.session = "told";
  options.camera_scale = 1.3f;
  for (int i = 0; i < 3; ++i) {
    auto reply = client_->Localise(kTestMapName, test::TourFeatures(i), options);
    ASSERT_TRUE(reply.ok()) << reply.status().ToString();
    EXPECT_FLOAT_EQ(reply->session().camera_scale(), 1.3f) << "frame " << i;
    EXPECT_FLOAT_EQ(reply->camera_scale(), 1.3f) << "frame " << i;
    // The tour's frames measure as the tour's camera: the stated 1.3 shows as wrong.
    EXPECT_NEAR(reply->session().measured_camera_scale(), 1.0f, 0.06f) << "frame " << i;
  }
  for (const float bad : {0.2f, 4.5f, std::nanf("")}) {
    options.camera_scale = bad;
    auto refused = client_->Localise(kTestMapName, test::TourFeatures(0), options);
    ASSERT_FALSE(refused.ok());
    EXPECT_NE(
        refused.status().message().find("INVALID_ARGUMENT: camera_scale must be in [0.25, 4]"),
        std::string::npos)
        << refused.status().message();
  }
  options.camera_scale.reset();
  EXPECT_TRUE(client_->Localise(kTestMapName, test::TourFeatures(0), options).ok());
}

// Two robots on one map, their frames interleaved on two connections: each session counts
// only its own frames, and robot A's answers are those it gets when it walks alone.
TEST_F(SessionTest, TwoSessionsDoNotDisturbEachOther) {
  std::vector<v1::SessionAnswer> alone;
  for (int i = 0; i < kTestTourLocations; ++i) {
    auto reply = Frame(client_.get(), i, "solo");
    ASSERT_TRUE(reply.ok());
    alone.push_back(reply->session());
  }
  std::unique_ptr<Client> other = Connect();
  ASSERT_NE(other, nullptr);
  for (int i = 0; i < kTestTourLocations; ++i) {
    auto a = Frame(client_.get(), i, "robot-a");
    auto b = Frame(other.get(), kTestTourLocations - 1 - i, "robot-b");  // walking back
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a->session().frames(), static_cast<uint32_t>(i + 1));
    EXPECT_EQ(b->session().frames(), static_cast<uint32_t>(i + 1));
    EXPECT_EQ(a->session().location(), alone[i].location()) << "frame " << i;
    EXPECT_NEAR(a->session().probability(), alone[i].probability(), 1e-4) << "frame " << i;
  }
}

// reset_session forgets the past: frames count from 1 again, start RESET. Without a session
// name it is refused.
TEST_F(SessionTest, ResetStartsAgain) {
  for (int i = 0; i < 4; ++i) ASSERT_TRUE(Frame(client_.get(), i, "r").ok());
  auto reply = Frame(client_.get(), 8, "r", /*reset=*/true);
  ASSERT_TRUE(reply.ok());
  EXPECT_EQ(reply->session().frames(), 1u);
  EXPECT_EQ(reply->session().start(), v1::RESET);
  LocaliseOptions nameless;
  nameless.reset_session = true;
  auto refused = client_->Localise(kTestMapName, test::TourFeatures(0), nameless);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("INVALID_ARGUMENT: reset_session needs a session"),
            std::string::npos)
      << refused.status().message();
  auto stateless = client_->Call(CarriedFrame(0, "", reply->session().state()));
  ASSERT_TRUE(stateless.ok());
  EXPECT_EQ(stateless->status(), v1::INVALID_ARGUMENT);
  EXPECT_NE(stateless->error().find("session_state needs a session"), std::string::npos)
      << stateless->error();
}

// The sessions the server keeps (a client that carries no state) follow the map's places: a
// reload that keeps them (the same file) continues them; a map of other places (here the same
// map as if retrained: its tour made at another time) restarts them, MAP_RELOADED, frames from 1.
TEST_F(SessionTest, MapReloadWithOtherPlacesRestartsTheSession) {
  const auto frame = [&](int i) {
    std::unique_ptr<Client> fresh = Connect();  // no carried state: the server's alone
    return Frame(fresh.get(), i, "r");
  };
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(frame(i).ok());
  auto reloaded = client_->Reload(kTestMapName);
  ASSERT_TRUE(reloaded.ok()) << reloaded.status().ToString();
  EXPECT_EQ(reloaded->map().version().generation(), 2u);
  auto same = frame(3);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->session().start(), v1::CONTINUED);
  EXPECT_EQ(same->session().frames(), 4u);

  auto map = LoadMap(dir_.MapPath());
  ASSERT_TRUE(map.ok());
  ASSERT_FALSE(map->experiences.empty());
  map->experiences.front().created_utc = "2000-01-01T00:00:00Z";
  ASSERT_TRUE(SaveMap(*map, dir_.MapPath()).ok());
  ASSERT_TRUE(client_->Reload(kTestMapName).ok());
  auto reply = frame(4);
  ASSERT_TRUE(reply.ok());
  EXPECT_EQ(reply->session().start(), v1::MAP_RELOADED);
  EXPECT_EQ(reply->session().frames(), 1u);
  EXPECT_GE(reply->map().generation(), 3u);  // the folder watcher may reload it too
  auto next = frame(5);
  ASSERT_TRUE(next.ok());
  EXPECT_EQ(next->session().start(), v1::CONTINUED);
  EXPECT_EQ(next->session().frames(), 2u);
}

// A carried state names the map's places (Map::PlacesKey), not the reload count nor the file's
// bytes: the same file reloaded, or a changed file of the same places (as a map extended by a
// walk of its route is), continues the session; a map of other places restarts it.
TEST_F(SessionTest, CarriedStateFollowsTheMapsPlaces) {
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(Frame(client_.get(), i, "r").ok());
  ASSERT_TRUE(client_->Reload(kTestMapName).ok());
  auto same = Frame(client_.get(), 3, "r");
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->session().start(), v1::CONTINUED);
  EXPECT_EQ(same->session().frames(), 4u);
  auto map = LoadMap(dir_.MapPath());
  ASSERT_TRUE(map.ok());
  map->provenance.tool_version = "another build";  // other bytes, the same places
  ASSERT_TRUE(SaveMap(*map, dir_.MapPath()).ok());
  auto reloaded = client_->Reload(kTestMapName);
  ASSERT_TRUE(reloaded.ok());
  EXPECT_GE(reloaded->map().version().generation(), 3u);
  auto kept = Frame(client_.get(), 4, "r");
  ASSERT_TRUE(kept.ok());
  EXPECT_EQ(kept->session().start(), v1::CONTINUED);
  EXPECT_EQ(kept->session().frames(), 5u);
  ASSERT_FALSE(map->experiences.empty());
  map->experiences.front().created_utc = "2000-01-01T00:00:00Z";  // as if retrained
  ASSERT_TRUE(SaveMap(*map, dir_.MapPath()).ok());
  ASSERT_TRUE(client_->Reload(kTestMapName).ok());
  auto changed = Frame(client_.get(), 5, "r");
  ASSERT_TRUE(changed.ok());
  EXPECT_EQ(changed->session().start(), v1::MAP_RELOADED);
  EXPECT_EQ(changed->session().frames(), 1u);
}

// Over-long, empty-with-reset and non-printable session names are INVALID_ARGUMENT with the
// reason; the server goes on serving sessions.
TEST_F(SessionTest, BadSessionNamesAreRefused) {
  for (const std::string& name : {std::string(129, 'x'), std::string("robot\n1"),
                                  std::string("a\0b", 3), std::string("caf\xc3\xa9")}) {
    auto reply = Frame(client_.get(), 0, name);
    ASSERT_FALSE(reply.ok());
    EXPECT_NE(reply.status().message().find("INVALID_ARGUMENT: session name"), std::string::npos)
        << reply.status().message();
  }
  auto fine = Frame(client_.get(), 0, std::string(128, 'x'));
  ASSERT_TRUE(fine.ok());
  EXPECT_EQ(fine->session().frames(), 1u);
}

// The server's counters: live sessions and their memory.
TEST_F(SessionTest, StatsCountSessions) {
  for (int s = 0; s < 5; ++s)
    ASSERT_TRUE(Frame(client_.get(), s, "robot-" + std::to_string(s)).ok());
  auto stats = client_->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->sessions(), 5u);
  EXPECT_GE(stats->session_memory_bytes(), 5u * TestStateSize() * sizeof(float));
}

// The fleet case: a session's frames answered by two server processes serving the same map
// file. The second server has never seen the session; with the state of the first's last
// reply it continues it exactly as the first would have.
TEST_F(SessionTest, AnotherServerContinuesFromTheCarriedState) {
  std::vector<v1::SessionAnswer> one_server;
  for (int i = 0; i < 7; ++i) {
    auto reply = Frame(client_.get(), i, "walk");
    ASSERT_TRUE(reply.ok());
    one_server.push_back(reply->session());
  }
  ServerOptions options = test::TestServerOptions();
  options.maps_dir = dir_.path();
  test::TestServer second = test::StartTestServerOnDir(options);
  ASSERT_FALSE(HasFatalFailure());
  auto other = Client::Connect(second.endpoint);
  ASSERT_TRUE(other.ok());
  std::string state;
  for (int i = 0; i < 6; ++i) {
    auto reply = Frame(client_.get(), i, "walk-2");
    ASSERT_TRUE(reply.ok());
    state = reply->session().state();
  }
  // The header, the filter's values and the camera's 64 bins (measured by now).
  EXPECT_EQ(state.size(), 44u + 4 * TestStateSize() + 2 * SequenceOptions::kCameraBins);
  auto reply = (*other)->Call(CarriedFrame(6, "walk-2", state));
  ASSERT_TRUE(reply.ok());
  ASSERT_EQ(reply->status(), v1::OK) << reply->error();
  const v1::SessionAnswer& s = reply->localise().session();
  EXPECT_EQ(s.start(), v1::CONTINUED);
  EXPECT_EQ(s.frames(), 7u);
  EXPECT_EQ(s.location(), one_server[6].location());
  EXPECT_NEAR(s.probability(), one_server[6].probability(), 1e-4);
  EXPECT_NEAR(s.track_support(), one_server[6].track_support(), 1e-6);  // carried in the state
  EXPECT_FLOAT_EQ(s.camera_scale(), one_server[6].camera_scale());
}

// A corrupt state, or one of another session, is INVALID_ARGUMENT saying so; the session
// itself is unharmed and goes on.
TEST_F(SessionTest, BadCarriedStatesAreRefused) {
  std::string state;
  for (int i = 0; i < 3; ++i) {
    auto reply = Frame(client_.get(), i, "mine");
    ASSERT_TRUE(reply.ok());
    state = reply->session().state();
  }
  std::string flipped = state;
  flipped[40] = static_cast<char>(flipped[40] ^ 1);
  for (const auto& [session, bytes, needle] :
       {std::tuple<std::string, std::string, std::string>{"mine", flipped, "checksum"},
        {"mine", "garbage", "not a state"},
        {"mine", state.substr(0, state.size() / 2), "not a state"},
        {"theirs", state, "another session"}}) {
    auto reply = client_->Call(CarriedFrame(3, session, bytes));
    ASSERT_TRUE(reply.ok());
    EXPECT_EQ(reply->status(), v1::INVALID_ARGUMENT);
    EXPECT_NE(reply->error().find(needle), std::string::npos) << reply->error();
  }
  auto next = Frame(client_.get(), 3, "mine");
  ASSERT_TRUE(next.ok());
  EXPECT_EQ(next->session().frames(), 4u);
}

// A state made against another map (another checksum) starts the session again, with the
// reason.
TEST_F(SessionTest, CarriedStateOfAnotherMapStartsAgain) {
  std::string state;
  for (int i = 0; i < 3; ++i) {
    auto reply = Frame(client_.get(), i, "r");
    ASSERT_TRUE(reply.ok());
    state = reply->session().state();
  }
  state[4] = static_cast<char>(state[4] ^ 1);  // the map checksum field, then re-seal it
  const uint32_t crc = Crc32(state.data(), state.size() - 4);
  std::memcpy(&state[state.size() - 4], &crc, 4);
  auto reply = client_->Call(CarriedFrame(3, "r", state));
  ASSERT_TRUE(reply.ok());
  ASSERT_EQ(reply->status(), v1::OK) << reply->error();
  EXPECT_EQ(reply->localise().session().start(), v1::MAP_RELOADED);
  EXPECT_EQ(reply->localise().session().frames(), 1u);
}

class BoundedSessionTest : public SessionTest {
 protected:
  void SetUp() override {}
};

// sessions.max_sessions: a new session beyond it drops the least recently used one, which
// then starts again as NEW.
TEST_F(BoundedSessionTest, LeastRecentlyUsedIsEvicted) {
  ServerOptions options = test::TestServerOptions();
  options.maps_dir = dir_.path();
  options.sessions.max_sessions = 2;
  Start(options);
  ASSERT_FALSE(HasFatalFailure());
  ASSERT_TRUE(Frame(client_.get(), 0, "a").ok());
  ASSERT_TRUE(Frame(client_.get(), 0, "b").ok());
  ASSERT_TRUE(Frame(client_.get(), 1, "a").ok());  // b is now the least recently used
  ASSERT_TRUE(Frame(client_.get(), 0, "c").ok());
  auto a = Frame(client_.get(), 2, "a");
  auto b = Frame(client_.get(), 1, "b");
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->session().start(), v1::CONTINUED);
  EXPECT_EQ(a->session().frames(), 3u);
  // b was dropped by the server, but its client sent back its state: it goes on.
  EXPECT_EQ(b->session().start(), v1::CONTINUED);
  EXPECT_EQ(b->session().frames(), 2u);
  // A client that does not carry the state (a fresh one) finds c dropped: a new session.
  std::unique_ptr<Client> fresh = Connect();
  auto c = Frame(fresh.get(), 1, "c");
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->session().start(), v1::NEW);
  auto stats = client_->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->sessions(), 2u);
  EXPECT_GE(stats->sessions_evicted(), 2u);  // b for c, then a or c for b
}

// sessions.idle_timeout_s: a session unused that long is gone (here 1 ms: the next frame
// always comes later than that).
TEST_F(BoundedSessionTest, IdleSessionExpires) {
  ServerOptions options = test::TestServerOptions();
  options.maps_dir = dir_.path();
  options.sessions.idle_timeout_s = 0.001;
  Start(options);
  ASSERT_FALSE(HasFatalFailure());
  ASSERT_TRUE(Frame(client_.get(), 0, "r").ok());
  std::unique_ptr<Client> fresh = Connect();  // carries no state: sees what the server kept
  auto again = Frame(fresh.get(), 1, "r");
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->session().start(), v1::NEW);
  EXPECT_EQ(again->session().frames(), 1u);
  auto stats = client_->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_GE(stats->sessions_expired(), 1u);
}

}  // namespace
}  // namespace sceneloc
