// The work behind the socket (server/request_handler.h), called directly: localise by JPEG
// and by feature set, sessions, the map list, stats and reloads, and an error reply with
// its own status for each bad request, on the real test map.
#include "server/request_handler.h"

#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <string>

#include "proto/wire.h"
#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

using Clock = std::chrono::steady_clock;
using test::kTestMapName;
using test::kTestTourLocations;

class RequestHandlerTest : public ::testing::Test {
 protected:
  void SetUp() override { MakeHandler(test::TestServerOptions()); }

  // A registry holding the test map (first load: generation 1) and a handler over it.
  void MakeHandler(const ServerOptions& options) {
    options_ = options;
    MapRegistry::Options registry_options;
    registry_options.self_test = options.matching;
    registry_ = std::make_unique<MapRegistry>(registry_options);
    ASSERT_TRUE(registry_->Load(test::TestMapPath()).ok());
    handler_ = std::make_unique<RequestHandler>(options_, registry_.get(), nullptr, &stats_);
  }

  v1::Reply Handle(const v1::Request& request, Clock::time_point received = Clock::now()) const {
    v1::Reply reply;
    handler_->Handle(request, received, &reply);
    return reply;
  }

  // A localise request for the test map carrying tour location `i` as a JPEG.
  static v1::Request JpegRequest(int i) {
    v1::Request request;
    request.set_request_id(100 + i);
    request.mutable_localise()->set_map(kTestMapName);
    request.mutable_localise()->set_jpeg(test::TourJpegs()[i]);
    return request;
  }

  // The same location as a feature set.
  static v1::Request FeaturesRequest(int i) {
    v1::Request request;
    request.mutable_localise()->set_map(kTestMapName);
    EncodeFeatureSet(test::TourFeatures(i), DescriptorEncoding::kFloat32,
                     request.mutable_localise()->mutable_features());
    return request;
  }

  // Expects an error reply with `status` whose message contains `expected`.
  static void ExpectError(const v1::Reply& reply, v1::StatusCode status,
                          const std::string& expected) {
    EXPECT_EQ(reply.status(), status) << reply.error();
    EXPECT_NE(reply.error().find(expected), std::string::npos) << reply.error();
    EXPECT_EQ(reply.kind_case(), v1::Reply::KIND_NOT_SET);
  }

  ServerOptions options_;
  ServerStats stats_;
  std::unique_ptr<MapRegistry> registry_;
  std::unique_ptr<RequestHandler> handler_;
};

// A tour JPEG is localised to its own location, with the map that answered, the request
// id echoed and the time each stage took.
TEST_F(RequestHandlerTest, LocalisesATourJpeg) {
  const v1::Reply reply = Handle(JpegRequest(5));
  ASSERT_EQ(reply.status(), v1::OK) << reply.error();
  EXPECT_EQ(reply.request_id(), 105u);
  const v1::LocaliseReply& r = reply.localise();
  ASSERT_GT(r.locations_size(), 0);
  EXPECT_EQ(r.locations(0).index(), 5);
  EXPECT_EQ(r.map().name(), kTestMapName);
  EXPECT_EQ(r.map().generation(), 1u);
  EXPECT_GT(r.num_features(), 0u);
  EXPECT_GT(r.timings().decode_ms(), 0.0);
  EXPECT_GE(r.timings().total_ms(), r.timings().extract_ms());
}

// A feature set is localised as its JPEG would be, without a decode.
TEST_F(RequestHandlerTest, LocalisesAFeatureSet) {
  const v1::Reply reply = Handle(FeaturesRequest(8));
  ASSERT_EQ(reply.status(), v1::OK) << reply.error();
  EXPECT_EQ(reply.localise().locations(0).index(), 8);
  EXPECT_EQ(reply.localise().timings().decode_ms(), 0.0);
  EXPECT_EQ(reply.localise().num_features(), static_cast<uint32_t>(test::TourFeatures(8).size()));
}

// top_k and min_confidence out of range, a session state without a session, no query
// and no request kind are each INVALID_ARGUMENT saying which.
TEST_F(RequestHandlerTest, RefusesMalformedRequests) {
  v1::Request request = FeaturesRequest(0);
  request.mutable_localise()->set_top_k(options_.limits.max_top_k + 1);
  ExpectError(Handle(request), v1::INVALID_ARGUMENT, "top_k must be in [0, ");
  request = FeaturesRequest(0);
  request.mutable_localise()->set_min_confidence(1.5f);
  ExpectError(Handle(request), v1::INVALID_ARGUMENT, "min_confidence must be in [0, 1]");
  request = FeaturesRequest(0);
  request.mutable_localise()->set_session_state("token");
  ExpectError(Handle(request), v1::INVALID_ARGUMENT, "session_state needs a session name");
  request.mutable_localise()->clear_session_state();
  request.mutable_localise()->clear_features();
  ExpectError(Handle(request), v1::INVALID_ARGUMENT, "carries no query");
  ExpectError(Handle(v1::Request()), v1::INVALID_ARGUMENT, "request has no kind");
}

// A map that is not served is NOT_FOUND, naming it.
TEST_F(RequestHandlerTest, UnknownMapIsNotFound) {
  v1::Request request = FeaturesRequest(0);
  request.mutable_localise()->set_map("elsewhere");
  ExpectError(Handle(request), v1::NOT_FOUND, "no map named 'elsewhere'");
}

// Bytes that are not a JPEG, and a JPEG larger than the limits, are refused before any
// decoding.
TEST_F(RequestHandlerTest, RefusesBadAndOversizedJpegs) {
  v1::Request request = JpegRequest(0);
  request.mutable_localise()->set_jpeg("not a jpeg at all");
  const v1::Reply garbage = Handle(request);
  EXPECT_NE(garbage.status(), v1::OK);
  EXPECT_FALSE(garbage.error().empty());
  ServerOptions small = test::TestServerOptions();
  small.limits.max_image_side = 320;
  MakeHandler(small);
  ExpectError(Handle(JpegRequest(0)), v1::RESOURCE_EXHAUSTED,
              "the server accepts at most 320 pixels per side");
}

// A request that arrives already past its time budget is DEADLINE_EXCEEDED.
TEST_F(RequestHandlerTest, RequestPastItsBudgetIsDeadlineExceeded) {
  const Clock::time_point long_ago =
      Clock::now() - std::chrono::milliseconds(options_.limits.max_request_ms + 1000);
  const v1::Reply reply = Handle(FeaturesRequest(2), long_ago);
  EXPECT_EQ(reply.status(), v1::DEADLINE_EXCEEDED) << reply.error();
  EXPECT_NE(reply.error().find("max_request_ms"), std::string::npos) << reply.error();
}

// Frames of one session are filtered together: the first starts it, the next continues
// it, and each reply carries the session's answer and its state.
TEST_F(RequestHandlerTest, SessionFramesContinueTheSession) {
  v1::Request first = FeaturesRequest(3);
  first.mutable_localise()->set_session("robot-1");
  const v1::Reply a = Handle(first);
  ASSERT_EQ(a.status(), v1::OK) << a.error();
  EXPECT_EQ(a.localise().session().start(), v1::NEW);
  EXPECT_EQ(a.localise().session().frames(), 1u);
  EXPECT_FALSE(a.localise().session().state().empty());
  v1::Request second = FeaturesRequest(4);
  second.mutable_localise()->set_session("robot-1");
  const v1::Reply b = Handle(second);
  ASSERT_EQ(b.status(), v1::OK) << b.error();
  EXPECT_EQ(b.localise().session().start(), v1::CONTINUED);
  EXPECT_EQ(b.localise().session().frames(), 2u);
  EXPECT_EQ(b.localise().session().name(), "robot-1");
  EXPECT_EQ(handler_->sessions().live, 1u);
}

// list_maps names the served map with its size; stats reports the counters and maps.
TEST_F(RequestHandlerTest, ListsMapsAndStats) {
  v1::Request list;
  list.mutable_list_maps();
  const v1::Reply maps = Handle(list);
  ASSERT_EQ(maps.list_maps().maps_size(), 1);
  const v1::MapInfo& info = maps.list_maps().maps(0);
  EXPECT_EQ(info.version().name(), kTestMapName);
  EXPECT_EQ(info.num_locations(), kTestTourLocations);
  EXPECT_GT(info.num_landmarks(), 0);
  stats_.RecordRequest();
  stats_.RecordReply("OK", false, 0);
  v1::Request stats;
  stats.mutable_stats();
  const v1::Reply s = Handle(stats);
  EXPECT_EQ(s.stats().requests(), 1u);
  EXPECT_EQ(s.stats().replies_by_status().at("OK"), 1u);
  EXPECT_EQ(s.stats().map_loads(), 1u);
  EXPECT_EQ(s.stats().maps_size(), 1);
}

// Only stats and list_maps are cheap enough for the I/O thread.
TEST_F(RequestHandlerTest, CheapRequests) {
  v1::Request request;
  request.mutable_stats();
  EXPECT_TRUE(RequestHandler::IsCheap(request));
  request.mutable_list_maps();
  EXPECT_TRUE(RequestHandler::IsCheap(request));
  EXPECT_FALSE(RequestHandler::IsCheap(FeaturesRequest(0)));
  request.mutable_reload_map()->set_map(kTestMapName);
  EXPECT_FALSE(RequestHandler::IsCheap(request));
}

// A reload names a map by a plain file stem; anything that could reach outside the maps
// folder is refused.
TEST_F(RequestHandlerTest, ReloadNamesArePlainStems) {
  for (const char* good : {"synthetic", "lab_2", "hall-B.v2"}) {
    v1::ReloadMapRequest request;
    request.set_map(good);
    EXPECT_TRUE(RequestHandler::CheckReload(request).ok()) << good;
  }
  for (const char* bad : {"", "../synthetic", ".hidden", "a/b", "a b", "x\\y"}) {
    v1::ReloadMapRequest request;
    request.set_map(bad);
    EXPECT_EQ(RequestHandler::CheckReload(request).code(), StatusCode::kInvalidArgument) << bad;
  }
}

// A reload loads <maps_dir>/<name>.scnl again (generation 2); its failure is an error
// reply with the load's status.
TEST_F(RequestHandlerTest, ReloadsFromTheMapsFolder) {
  v1::Request request;
  request.set_request_id(9);
  request.mutable_reload_map()->set_map(kTestMapName);
  const v1::Reply reply = Handle(request);
  ASSERT_EQ(reply.status(), v1::OK) << reply.error();
  EXPECT_EQ(reply.reload_map().map().version().generation(), 2u);
  request.mutable_reload_map()->set_map("absent");
  ExpectError(Handle(request), v1::NOT_FOUND, "absent.scnl");
  v1::Reply filled;
  RequestHandler::FillReloadReply(
      4, StatusOr<std::shared_ptr<const LoadedMap>>(DataLoss("map file 'x' is truncated")),
      &filled);
  EXPECT_EQ(filled.request_id(), 4u);
  ExpectError(filled, v1::DATA_LOSS, "is truncated");
}

}  // namespace
}  // namespace sceneloc
