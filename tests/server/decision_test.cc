// The decision in every answer, through a real server on tcp://127.0.0.1:*: the generated
// tour's test pass is LOCALISED, frames of another scene come back UNKNOWN (status OK,
// ranked candidates present), a request may set its own threshold, a bad one is refused,
// and a map made before calibration existed serves with the paper's confidence.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "client/client.h"
#include "common/synthetic/tour_generator.h"
#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;
using test::kTestMapName;
using test::kTestTourLocations;

// JPEG bytes of a cluttered room-like scene, nothing like the generated street.
std::string ForeignFrame(uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> x(0, 640), y(0, 360), v(0, 255), r(5, 60);
  cv::Mat image(360, 640, CV_8UC3);
  cv::randu(image, cv::Scalar::all(60), cv::Scalar::all(200));
  cv::GaussianBlur(image, image, cv::Size(0, 0), 25);
  for (int i = 0; i < 40; ++i) {
    const cv::Scalar colour(v(rng), v(rng), v(rng));
    if (i % 3 == 0) cv::circle(image, {x(rng), y(rng)}, r(rng), colour, cv::FILLED);
    if (i % 3 == 1) cv::rectangle(image, {x(rng), y(rng)}, {x(rng), y(rng)}, colour, 4);
    if (i % 3 == 2) cv::line(image, {x(rng), y(rng)}, {x(rng), y(rng)}, colour, 2);
  }
  std::vector<uchar> jpeg;
  cv::imencode(".jpg", image, jpeg);
  return std::string(jpeg.begin(), jpeg.end());
}

class DecisionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = test::StartTestServer(test::TestServerOptions());
    ASSERT_FALSE(HasFatalFailure());
    ClientOptions options;
    options.timeout_ms = 20000;
    options.retries = 0;
    auto client = Client::Connect(server_.endpoint, options);
    ASSERT_TRUE(client.ok());
    client_ = std::move(client).value();
  }

  test::TestServer server_;
  std::unique_ptr<Client> client_;
};

// The test pass of the generated tour is LOCALISED with a high confidence; frames of another
// scene are UNKNOWN, with status OK and their ranked candidates still there.
TEST_F(DecisionTest, OwnRouteLocalisedForeignSceneUnknown) {
  TourOptions tour;
  tour.num_locations = kTestTourLocations;
  auto test_pass = RenderTourJpegs(tour, kTestPass);
  ASSERT_TRUE(test_pass.ok());
  int localised = 0;
  for (int i = 0; i < kTestTourLocations; ++i) {
    auto reply = client_->Localise(kTestMapName, (*test_pass)[i]);
    ASSERT_TRUE(reply.ok()) << reply.status().ToString();
    EXPECT_EQ(reply->confidence_model(), "calibrated");
    EXPECT_EQ(reply->tolerance(), 2);
    EXPECT_FLOAT_EQ(reply->min_confidence(), 0.8f);
    if (reply->decision() == v1::LOCALISED) {
      ++localised;
      EXPECT_LE(std::abs(reply->locations(0).index() - i), 2);
      EXPECT_GE(reply->confidence(), 0.8f);
    }
  }
  EXPECT_GE(localised, kTestTourLocations - 1);
  for (uint32_t seed = 1; seed <= 6; ++seed) {
    auto reply = client_->Localise(kTestMapName, ForeignFrame(seed));
    ASSERT_TRUE(reply.ok()) << reply.status().ToString();
    EXPECT_EQ(reply->decision(), v1::UNKNOWN)
        << "seed " << seed << " confidence " << reply->confidence();
    EXPECT_LT(reply->confidence(), 0.8f);
    EXPECT_FALSE(reply->locations().empty());
  }
}

// A request's own threshold decides; the reply says which threshold it used.
TEST_F(DecisionTest, RequestSetsItsOwnThreshold) {
  LocaliseOptions everything;
  everything.min_confidence = 0.0f;
  auto reply = client_->Localise(kTestMapName, ForeignFrame(9), everything);
  ASSERT_TRUE(reply.ok());
  EXPECT_EQ(reply->decision(), v1::LOCALISED);
  EXPECT_FLOAT_EQ(reply->min_confidence(), 0.0f);
  LocaliseOptions strict;
  strict.min_confidence = 1.0f;
  reply = client_->Localise(kTestMapName, ForeignFrame(9), strict);
  ASSERT_TRUE(reply.ok());
  EXPECT_EQ(reply->decision(), v1::UNKNOWN);
}

// A reply that carries no decision (an older server, a field lost on the way) must read as
// "do not act on it".
TEST(DecisionWireTest, MissingDecisionReadsUnknown) {
  EXPECT_EQ(v1::LocaliseReply().decision(), v1::UNKNOWN);
  v1::LocaliseReply parsed;
  ASSERT_TRUE(parsed.ParseFromString(std::string()));
  EXPECT_EQ(parsed.decision(), v1::UNKNOWN);
}

// A threshold outside [0, 1] (or not a number) is refused with INVALID_ARGUMENT.
TEST_F(DecisionTest, ThresholdOutsideTheUnitIntervalRefused) {
  for (float bad : {1.5f, -0.1f, std::nanf("")}) {
    LocaliseOptions options;
    options.min_confidence = bad;
    auto reply = client_->Localise(kTestMapName, test::TourFeatures(2), options);
    ASSERT_FALSE(reply.ok());
    EXPECT_NE(reply.status().message().find("INVALID_ARGUMENT"), std::string::npos);
    EXPECT_NE(reply.status().message().find("min_confidence"), std::string::npos);
  }
}

// The map list names each map's confidence model; a map of format version 1 (no
// calibration) loads, serves, and answers with the paper's.
TEST_F(DecisionTest, MapsWithoutCalibrationServeThePaperModel) {
  test::TempMapsDir dir("decision_v1");
  fs::copy_file(SCENELOC_TEST_DATA "/v1_map.scnl", fs::path(dir.path()) / "old.scnl");
  ServerOptions options = test::TestServerOptions();
  options.maps_dir = dir.path();
  test::TestServer server = test::StartTestServerOnDir(options);
  ASSERT_FALSE(HasFatalFailure());
  auto client = Client::Connect(server.endpoint);
  ASSERT_TRUE(client.ok());
  auto maps = (*client)->ListMaps();
  ASSERT_TRUE(maps.ok()) << maps.status().ToString();
  std::map<std::string, std::string> model;
  for (const v1::MapInfo& m : maps->maps()) model[m.version().name()] = m.confidence_model();
  EXPECT_EQ(model["old"], "paper");
  EXPECT_EQ(model[kTestMapName], "calibrated");
  TourOptions tour;
  tour.num_locations = 6;
  tour.image_width = 320;
  tour.image_height = 180;
  auto frames = RenderTourJpegs(tour, kTrainingPass);
  ASSERT_TRUE(frames.ok());
  auto reply = (*client)->Localise("old", (*frames)[3]);
  ASSERT_TRUE(reply.ok()) << reply.status().ToString();
  EXPECT_EQ(reply->confidence_model(), "paper");
  EXPECT_LE(std::abs(reply->locations(0).index() - 3), 1);
}

}  // namespace
}  // namespace sceneloc
