// A real server on tcp://127.0.0.1:* serving a map trained from a generated tour, driven
// through real sockets end to end: the answers a client gets, and every kind of bad input
// refused on its way through the I/O thread, the workers and the request handler. The
// server's parts have their own tests (server_io_test, server_dispatch_test, ...).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "common/map/map_io.h"
#include "common/matching/localiser.h"
#include "proto/wire.h"
#include "tests/server/server_call_support.h"

namespace sceneloc {
namespace {

using test::kTestMapName;
using test::kTestTourLocations;
using test::LocaliseFeatures;
using test::MustConnect;
using test::RawCall;
using test::ServerTest;

// A tour JPEG sent as bytes comes back as its own location, naming the map version.
TEST_F(ServerTest, JpegRoundTripFindsTheRightLocation) {
  MapFileInfo info;
  ASSERT_TRUE(LoadMap(test::TestMapPath(), &info).ok());
  for (int i : {0, 5, kTestTourLocations - 1}) {
    auto reply = client_->Localise(kTestMapName, test::TourJpegs()[i]);
    ASSERT_TRUE(reply.ok()) << reply.status().ToString();
    ASSERT_FALSE(reply->locations().empty());
    EXPECT_EQ(reply->locations(0).index(), i);
    EXPECT_EQ(reply->locations(0).image_name(),
              "Image" + std::string(i < 10 ? "00" : "0") + std::to_string(i) + ".jpg");
    EXPECT_GT(reply->confidence(), 0.0f);
    EXPECT_EQ(reply->map().name(), kTestMapName);
    EXPECT_EQ(reply->map().generation(), 1u);
    EXPECT_EQ(reply->map().checksum(), info.checksum);
    EXPECT_GT(reply->timings().decode_ms(), 0.0);
    EXPECT_GT(reply->timings().extract_ms(), 0.0);
    EXPECT_GE(reply->timings().total_ms(), reply->timings().descriptor_ms());
  }
}

// A feature set sent over the wire gets exactly the answer the engine gives in process.
TEST_F(ServerTest, FeatureSetRoundTripMatchesTheEngine) {
  auto map = LoadMap(test::TestMapPath());
  ASSERT_TRUE(map.ok());
  const int i = 7;
  auto local = Localise(test::TourFeatures(i), *map, MatchOptions(), nullptr);
  ASSERT_TRUE(local.ok());
  auto reply = client_->Localise(kTestMapName, test::TourFeatures(i));
  ASSERT_TRUE(reply.ok()) << reply.status().ToString();
  ASSERT_EQ(reply->locations_size(), static_cast<int>(local->ranked.size()));
  for (int k = 0; k < reply->locations_size(); ++k) {
    EXPECT_EQ(reply->locations(k).index(), local->ranked[static_cast<size_t>(k)].index);
    EXPECT_FLOAT_EQ(reply->locations(k).likelihood(),
                    local->ranked[static_cast<size_t>(k)].likelihood);
  }
  EXPECT_EQ(reply->locations(0).index(), i);
  EXPECT_FLOAT_EQ(reply->confidence(), local->confidence);
  EXPECT_EQ(reply->num_features(), static_cast<uint32_t>(test::TourFeatures(i).size()));
  EXPECT_EQ(reply->timings().decode_ms(), 0.0);
}

// uint8 descriptors (a quarter of the bytes) still find the right location, and top_k
// is honoured.
TEST_F(ServerTest, Uint8FeatureSetAndTopK) {
  LocaliseOptions options;
  options.top_k = 2;
  options.encoding = DescriptorEncoding::kUint8;
  auto reply = client_->Localise(kTestMapName, test::TourFeatures(3), options);
  ASSERT_TRUE(reply.ok()) << reply.status().ToString();
  ASSERT_EQ(reply->locations_size(), 2);
  EXPECT_EQ(reply->locations(0).index(), 3);
}

// Every kind of bad input gets its own error reply, while a well-behaved client on
// another thread keeps getting correct answers; Stats counts each refusal.
TEST_F(ServerTest, BadInputsGetErrorsWhileOthersAreServed) {
  std::atomic<bool> done{false};
  std::atomic<int> good_ok{0}, good_bad{0};
  std::thread good([&] {
    auto client = MustConnect(server_.endpoint);
    for (int n = 0; client != nullptr && (!done || n < 2); ++n) {
      auto reply = client->Localise(kTestMapName, test::TourFeatures(n % kTestTourLocations));
      (reply.ok() && reply->locations(0).index() == n % kTestTourLocations ? good_ok : good_bad)++;
    }
  });

  auto expect_status = [&](const v1::Request& request, v1::StatusCode code, const char* what) {
    auto reply = client_->Call(request);
    ASSERT_TRUE(reply.ok()) << what;
    EXPECT_EQ(reply->status(), code) << what << ": " << reply->error();
    EXPECT_FALSE(reply->error().empty()) << what;
  };
  const FeatureSet& f = test::TourFeatures(2);

  v1::Request corrupt_jpeg;
  corrupt_jpeg.mutable_localise()->set_map(kTestMapName);
  std::string jpeg = test::TourJpegs()[2];
  corrupt_jpeg.mutable_localise()->set_jpeg(jpeg.substr(0, 300));  // header only, no image
  expect_status(corrupt_jpeg, v1::INVALID_ARGUMENT, "truncated JPEG");
  corrupt_jpeg.mutable_localise()->set_jpeg("not a jpeg at all");
  expect_status(corrupt_jpeg, v1::INVALID_ARGUMENT, "not a JPEG");
  std::string garbled = jpeg;
  for (size_t k = garbled.size() / 3; k < garbled.size() - 2; k += 7) garbled[k] = '\xff';
  corrupt_jpeg.mutable_localise()->set_jpeg(garbled);
  auto garbled_reply = client_->Call(corrupt_jpeg);  // decodes to junk or fails: no crash
  ASSERT_TRUE(garbled_reply.ok());

  v1::Request wrong_length = LocaliseFeatures(f);
  wrong_length.mutable_localise()
      ->mutable_features()
      ->mutable_local()
      ->mutable_float32()
      ->RemoveLast();
  expect_status(wrong_length, v1::INVALID_ARGUMENT, "short descriptors");

  v1::Request nan = LocaliseFeatures(f);
  nan.mutable_localise()->mutable_features()->mutable_context()->set_float32(5, std::nanf(""));
  expect_status(nan, v1::INVALID_ARGUMENT, "NaN descriptor");

  v1::Request inf_keypoint = LocaliseFeatures(f);
  inf_keypoint.mutable_localise()->mutable_features()->mutable_keypoints(0)->set_x(INFINITY);
  expect_status(inf_keypoint, v1::INVALID_ARGUMENT, "infinite keypoint");

  FeatureSet many;
  many.image_width = 640;
  many.image_height = 360;
  many.keypoints.resize(8193);
  many.local = DescriptorMatrix::Zero(8193, kDescriptorSize);
  many.context = many.local;
  expect_status(LocaliseFeatures(many), v1::RESOURCE_EXHAUSTED, "too many keypoints");

  v1::Request oversized;
  oversized.mutable_localise()->set_map(kTestMapName);
  oversized.mutable_localise()->set_jpeg(std::string(9 << 20, '\0'));
  expect_status(oversized, v1::RESOURCE_EXHAUSTED, "oversized message");

  v1::Request no_query;
  no_query.mutable_localise()->set_map(kTestMapName);
  expect_status(no_query, v1::INVALID_ARGUMENT, "no query");
  expect_status(v1::Request(), v1::INVALID_ARGUMENT, "no kind");

  // A frame that is not a protobuf, and a request in too many frames.
  EXPECT_EQ(RawCall(server_.endpoint, {"", "\xff\xff\xff garbage"}).status(), v1::INVALID_ARGUMENT);
  EXPECT_EQ(RawCall(server_.endpoint, {"a", "b", "c"}).status(), v1::INVALID_ARGUMENT);

  done = true;
  good.join();
  EXPECT_GE(good_ok.load(), 2);
  EXPECT_EQ(good_bad.load(), 0);

  auto stats = client_->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_GE(stats->replies_by_status().at("INVALID_ARGUMENT"), 8u);
  EXPECT_GE(stats->replies_by_status().at("RESOURCE_EXHAUSTED"), 2u);
  EXPECT_GE(stats->replies_by_status().at("OK"), static_cast<uint64_t>(good_ok.load()));
  EXPECT_EQ(stats->localise_latency_ms().count(), stats->replies_by_status().at("OK"));
  EXPECT_GT(stats->localise_latency_ms().p50(), 0.0);
  EXPECT_LE(stats->localise_latency_ms().p50(), stats->localise_latency_ms().p99());
}

// A JPEG whose header claims a huge image is refused before it is decoded.
TEST_F(ServerTest, HugeJpegIsRefusedFromItsHeader) {
  std::string jpeg = test::TourJpegs()[0];
  // Patch the frame header (SOF0: FF C0, length, precision, height, width) to 60000x60000.
  const size_t sof = jpeg.find("\xff\xc0");
  ASSERT_NE(sof, std::string::npos);
  jpeg[sof + 5] = jpeg[sof + 7] = static_cast<char>(0xEA);
  jpeg[sof + 6] = jpeg[sof + 8] = static_cast<char>(0x60);
  auto reply = client_->Localise(kTestMapName, jpeg);
  EXPECT_EQ(reply.status().code(), StatusCode::kResourceExhausted);
  EXPECT_NE(reply.status().message().find("60000x60000"), std::string::npos)
      << reply.status().message();
}

// JPEGs too small for the extractor (1x1, 4x4, 4096x1, 1x4096) are INVALID_ARGUMENT naming
// the minimum, not INTERNAL, and the server goes on serving.
TEST_F(ServerTest, TinyJpegsAreInvalidArgumentNamingTheMinimum) {
  for (const cv::Size size :
       {cv::Size(1, 1), cv::Size(4, 4), cv::Size(4096, 1), cv::Size(1, 4096)}) {
    SCOPED_TRACE(std::to_string(size.width) + "x" + std::to_string(size.height));
    std::vector<uchar> bytes;
    ASSERT_TRUE(cv::imencode(".jpg", cv::Mat(size, CV_8UC3, cv::Scalar(90, 120, 200)), bytes));
    auto reply = client_->Localise(kTestMapName, std::string(bytes.begin(), bytes.end()));
    ASSERT_FALSE(reply.ok());
    EXPECT_EQ(reply.status().code(), StatusCode::kInvalidArgument) << reply.status().ToString();
    EXPECT_NE(reply.status().message().find("at least 16 pixels"), std::string::npos)
        << reply.status().message();
  }
  auto good = client_->Localise(kTestMapName, test::TourJpegs()[1]);
  ASSERT_TRUE(good.ok()) << good.status().ToString();
}

// A progressive JPEG with 200 extra scans (a decompression bomb: each scan is a full
// decoding pass) is refused from its markers before decoding, naming the limit.
TEST_F(ServerTest, JpegWithThousandsOfScansIsRefusedUndecoded) {
  const cv::Mat frame =
      cv::imdecode(std::vector<uchar>(test::TourJpegs()[3].begin(), test::TourJpegs()[3].end()),
                   cv::IMREAD_COLOR);
  std::vector<uchar> encoded;
  ASSERT_TRUE(cv::imencode(".jpg", frame, encoded, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
  const std::string progressive(encoded.begin(), encoded.end());
  auto fine = client_->Localise(kTestMapName, progressive);
  ASSERT_TRUE(fine.ok()) << fine.status().ToString();
  EXPECT_EQ(fine->locations(0).index(), 3);
  const size_t last_scan = progressive.rfind("\xff\xda");
  const size_t end = progressive.size() - 2;  // the end-of-image marker
  std::string bomb = progressive.substr(0, end);
  for (int i = 0; i < 200; ++i) bomb += progressive.substr(last_scan, end - last_scan);
  bomb += "\xff\xd9";
  auto refused = client_->Localise(kTestMapName, bomb);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kResourceExhausted);
  EXPECT_NE(refused.status().message().find("scans; the server accepts at most 64"),
            std::string::npos)
      << refused.status().message();
}

// A request past limits.max_request_ms ends with DEADLINE_EXCEEDED saying where and what
// each stage took (a 1 ms budget: decoding and extracting a JPEG alone take longer), and
// the server keeps serving.
TEST(ServerDeadlineTest, RequestPastItsBudgetIsDeadlineExceeded) {
  ServerOptions options = test::TestServerOptions();
  options.limits.max_request_ms = 1;
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  auto client = MustConnect(server.endpoint);
  ASSERT_NE(client, nullptr);
  auto reply = client->Localise(kTestMapName, test::TourJpegs()[2]);
  ASSERT_FALSE(reply.ok());
  EXPECT_EQ(reply.status().code(), StatusCode::kDeadlineExceeded) << reply.status().ToString();
  EXPECT_NE(reply.status().message().find("max_request_ms"), std::string::npos)
      << reply.status().message();
  EXPECT_NE(reply.status().message().find("extraction"), std::string::npos)
      << reply.status().message();
  auto stats = client->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->replies_by_status().at("DEADLINE_EXCEEDED"), 1u);
}

}  // namespace
}  // namespace sceneloc
