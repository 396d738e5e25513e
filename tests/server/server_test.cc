// A real server on tcp://127.0.0.1:* serving a map trained from a generated tour, driven
// through real sockets: answers, bad input, overload, shutdown.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <thread>
#include <zmq.hpp>
#include <zmq_addon.hpp>

#include "client/client.h"
#include "common/map/map_io.h"
#include "common/matching/localiser.h"
#include "tests/server/server_test_support.h"

namespace sceneloc {
namespace {

using test::kTestMapName;
using test::kTestTourLocations;

// Sends raw frames on a fresh DEALER and waits (up to 20 s) for one reply.
v1::Reply RawCall(const std::string& endpoint, const std::vector<std::string>& frames) {
  zmq::context_t context;
  zmq::socket_t socket(context, zmq::socket_type::dealer);
  socket.set(zmq::sockopt::linger, 0);
  socket.connect(endpoint);
  for (size_t i = 0; i < frames.size(); ++i) {
    socket.send(zmq::buffer(frames[i]),
                i + 1 < frames.size() ? zmq::send_flags::sndmore : zmq::send_flags::none);
  }
  zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
  v1::Reply reply;
  if (zmq::poll(&item, 1, std::chrono::seconds(20)) == 0) {
    ADD_FAILURE() << "no reply";
    return reply;
  }
  std::vector<zmq::message_t> parts;
  (void)zmq::recv_multipart(socket, std::back_inserter(parts));
  EXPECT_TRUE(reply.ParseFromArray(parts.back().data(), static_cast<int>(parts.back().size())));
  return reply;
}

std::unique_ptr<Client> MustConnect(const std::string& endpoint, int timeout_ms = 20000) {
  ClientOptions options;
  options.timeout_ms = timeout_ms;
  options.retries = 0;
  auto client = Client::Connect(endpoint, options);
  EXPECT_TRUE(client.ok()) << client.status().ToString();
  return client.ok() ? std::move(client).value() : nullptr;
}

v1::Request LocaliseFeatures(const FeatureSet& features) {
  v1::Request request;
  request.mutable_localise()->set_map(kTestMapName);
  EncodeFeatureSet(features, DescriptorEncoding::kFloat32,
                   request.mutable_localise()->mutable_features());
  return request;
}

class ServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = test::StartTestServer(test::TestServerOptions());
    ASSERT_FALSE(HasFatalFailure());
    ASSERT_NE(server_.server, nullptr);
    client_ = MustConnect(server_.endpoint);
    ASSERT_NE(client_, nullptr);
  }

  test::TestServer server_;
  std::unique_ptr<Client> client_;
};

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

// Several clients at once, each on its own thread and socket, all get correct answers.
TEST_F(ServerTest, ConcurrentClientsAllAnsweredCorrectly) {
  constexpr int kClients = 4, kRequests = 4;
  std::atomic<int> correct{0};
  std::vector<std::thread> threads;
  for (int c = 0; c < kClients; ++c) {
    threads.emplace_back([&, c] {
      auto client = MustConnect(server_.endpoint);
      if (client == nullptr) return;
      for (int r = 0; r < kRequests; ++r) {
        const int i = (c * kRequests + r) % kTestTourLocations;
        auto reply = (r % 2 == 0) ? client->Localise(kTestMapName, test::TourFeatures(i))
                                  : client->Localise(kTestMapName, test::TourJpegs()[i]);
        if (reply.ok() && !reply->locations().empty() && reply->locations(0).index() == i) {
          ++correct;
        }
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(correct.load(), kClients * kRequests);
}

// A map name the server does not serve gets NOT_FOUND.
TEST_F(ServerTest, UnknownMapIsNotFound) {
  v1::Request request = LocaliseFeatures(test::TourFeatures(0));
  request.mutable_localise()->set_map("no_such_map");
  auto reply = client_->Call(request);
  ASSERT_TRUE(reply.ok());
  EXPECT_EQ(reply->status(), v1::NOT_FOUND);
  EXPECT_NE(reply->error().find("no_such_map"), std::string::npos);
  EXPECT_FALSE(reply->has_localise());
}

// ListMaps names the map with its generation, checksum and size.
TEST_F(ServerTest, ListMapsShowsTheLoadedMap) {
  auto maps = client_->ListMaps();
  ASSERT_TRUE(maps.ok());
  ASSERT_EQ(maps->maps_size(), 1);
  EXPECT_EQ(maps->maps(0).version().name(), kTestMapName);
  EXPECT_EQ(maps->maps(0).version().generation(), 1u);
  EXPECT_EQ(maps->maps(0).num_locations(), kTestTourLocations);
  EXPECT_GT(maps->maps(0).num_landmarks(), 100);
  EXPECT_GT(maps->maps(0).memory_bytes(), 0u);
}

// ReloadMap reloads the file: a new generation, the same checksum; later answers name it.
TEST_F(ServerTest, ReloadMapBumpsTheGeneration) {
  auto reloaded = client_->Reload(kTestMapName);
  ASSERT_TRUE(reloaded.ok()) << reloaded.status().ToString();
  EXPECT_EQ(reloaded->map().version().generation(), 2u);
  auto reply = client_->Localise(kTestMapName, test::TourFeatures(1));
  ASSERT_TRUE(reply.ok());
  EXPECT_EQ(reply->map().generation(), 2u);
  auto missing = client_->Reload("../etc/passwd");
  EXPECT_EQ(missing.status().code(), StatusCode::kInvalidArgument);
  auto absent = client_->Reload("absent");
  EXPECT_EQ(absent.status().code(), StatusCode::kNotFound);
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

// A DEALER socket connected to `endpoint` that has sent `count` copies of `request` back
// to back, with request ids 1..count, without waiting for any reply.
zmq::socket_t SendBurst(zmq::context_t* context, const std::string& endpoint, v1::Request request,
                        int count) {
  zmq::socket_t socket(*context, zmq::socket_type::dealer);
  socket.set(zmq::sockopt::linger, 0);
  socket.connect(endpoint);
  for (int i = 1; i <= count; ++i) {
    request.set_request_id(static_cast<uint64_t>(i));
    socket.send(zmq::message_t(), zmq::send_flags::sndmore);
    socket.send(zmq::buffer(request.SerializeAsString()), zmq::send_flags::none);
  }
  return socket;
}

// Reads replies from `socket` until `count` distinct request ids have come (or 60 s have
// passed), expecting no request answered twice; calls `check` on each. Returns the ids.
std::set<uint64_t> CollectReplies(zmq::socket_t* socket, int count,
                                  const std::function<void(const v1::Reply&)>& check) {
  std::set<uint64_t> ids;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (static_cast<int>(ids.size()) < count && std::chrono::steady_clock::now() < deadline) {
    zmq::pollitem_t item{socket->handle(), 0, ZMQ_POLLIN, 0};
    if (zmq::poll(&item, 1, std::chrono::seconds(1)) == 0) continue;
    std::vector<zmq::message_t> parts;
    if (!zmq::recv_multipart(*socket, std::back_inserter(parts))) {
      ADD_FAILURE() << "receive failed";
      break;
    }
    v1::Reply reply;
    if (!reply.ParseFromArray(parts.back().data(), static_cast<int>(parts.back().size()))) {
      ADD_FAILURE() << "a reply that is not a sceneloc.v1.Reply";
      continue;
    }
    EXPECT_TRUE(ids.insert(reply.request_id()).second) << "two replies to " << reply.request_id();
    check(reply);
  }
  return ids;
}

// A server with one worker and a queue of one, flooded: every request gets exactly one
// reply, some OVERLOADED, none dropped.
TEST(ServerOverloadTest, FullQueueRepliesOverloadedNeverDrops) {
  ServerOptions options = test::TestServerOptions();
  options.threads = 1;
  options.queue_capacity = 1;
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);

  zmq::context_t context;
  constexpr int kRequests = 24;
  zmq::socket_t socket =
      SendBurst(&context, server.endpoint, LocaliseFeatures(test::TourFeatures(4)), kRequests);
  int ok = 0, overloaded = 0;
  const std::set<uint64_t> ids = CollectReplies(&socket, kRequests, [&](const v1::Reply& reply) {
    if (reply.status() == v1::OK) {
      ++ok;
      EXPECT_EQ(reply.localise().locations(0).index(), 4);
    } else {
      EXPECT_EQ(reply.status(), v1::OVERLOADED) << reply.error();
      ++overloaded;
    }
  });
  EXPECT_EQ(static_cast<int>(ids.size()), kRequests);
  EXPECT_GE(ok, 1);
  EXPECT_GE(overloaded, 1);
  EXPECT_EQ(ok + overloaded, kRequests);
}

// 900 reload_map requests at once: every one gets exactly one reply, OK (coalesced loads)
// or OVERLOADED, in seconds rather than a backlog of 900 loads; a well-behaved client is
// served meanwhile, and the server shuts down promptly afterwards. (900 stays under
// ZeroMQ's default high-water mark of 1,000 messages: a client that sends more than that
// without reading loses the replies beyond it, by ZeroMQ's design.)
TEST(ServerOverloadTest, ReloadFloodIsCoalescedAndBounded) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  zmq::context_t context;
  constexpr int kRequests = 900;
  v1::Request reload;
  reload.mutable_reload_map()->set_map(kTestMapName);
  const auto start = std::chrono::steady_clock::now();
  zmq::socket_t socket = SendBurst(&context, server.endpoint, reload, kRequests);
  auto good = MustConnect(server.endpoint);
  ASSERT_NE(good, nullptr);
  auto served = good->Localise(kTestMapName, test::TourFeatures(5));
  ASSERT_TRUE(served.ok()) << served.status().ToString();
  int ok = 0, overloaded = 0;
  const std::set<uint64_t> ids = CollectReplies(&socket, kRequests, [&](const v1::Reply& reply) {
    if (reply.status() == v1::OK) {
      ++ok;
    } else {
      EXPECT_EQ(reply.status(), v1::OVERLOADED) << reply.error();
      ++overloaded;
    }
  });
  EXPECT_EQ(static_cast<int>(ids.size()), kRequests);
  EXPECT_GE(ok, 1);
  EXPECT_GE(overloaded, kRequests / 2);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(30));
  const auto stopping = std::chrono::steady_clock::now();
  server.server->Shutdown();
  EXPECT_LT(std::chrono::steady_clock::now() - stopping, std::chrono::seconds(10));
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

// A JPEG of the test tour's location `i` enlarged to 2400x1350 at quality 95 (~1 MB), so
// that each request is large and takes a worker a while (decoding, resizing, extracting).
std::string LargeJpeg(int i) {
  cv::Mat image = cv::imdecode(
      cv::Mat(1, static_cast<int>(test::TourJpegs()[static_cast<size_t>(i)].size()), CV_8U,
              const_cast<char*>(test::TourJpegs()[static_cast<size_t>(i)].data())),
      cv::IMREAD_COLOR);
  cv::Mat large;
  cv::resize(image, large, cv::Size(2400, 1350), 0, 0, cv::INTER_CUBIC);
  std::vector<uint8_t> bytes;
  cv::imencode(".jpg", large, bytes, {cv::IMWRITE_JPEG_QUALITY, 95});
  return std::string(bytes.begin(), bytes.end());
}

v1::Request LocaliseJpeg(const std::string& jpeg) {
  v1::Request request;
  request.mutable_localise()->set_map(kTestMapName);
  request.mutable_localise()->set_jpeg(jpeg);
  return request;
}

// One connection that pipelines requests gets OVERLOADED beyond its share
// (limits.max_in_flight_per_client), naming the limit, while another connection is served.
TEST(ServerFairnessTest, OneConnectionCannotTakeTheWholeQueue) {
  ServerOptions options = test::TestServerOptions();
  options.threads = 1;
  options.limits.max_in_flight_per_client = 2;
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  zmq::context_t context;
  constexpr int kRequests = 8;
  zmq::socket_t flood = SendBurst(&context, server.endpoint, LocaliseJpeg(LargeJpeg(3)), kRequests);
  auto good = MustConnect(server.endpoint);
  auto served = good->Localise(kTestMapName, test::TourFeatures(5));
  ASSERT_TRUE(served.ok()) << served.status().ToString();
  EXPECT_EQ(served->locations(0).index(), 5);
  int ok = 0, overloaded = 0;
  const std::set<uint64_t> ids = CollectReplies(&flood, kRequests, [&](const v1::Reply& reply) {
    if (reply.status() == v1::OK) {
      ++ok;
      return;
    }
    ++overloaded;
    EXPECT_EQ(reply.status(), v1::OVERLOADED) << reply.error();
    EXPECT_NE(reply.error().find("limits.max_in_flight_per_client"), std::string::npos)
        << reply.error();
    // A hint to retry once one of its requests is done: about one request's work.
    EXPECT_GE(reply.retry_after_ms(), 10u);
    EXPECT_LE(reply.retry_after_ms(), 10000u);
  });
  EXPECT_EQ(static_cast<int>(ids.size()), kRequests);
  EXPECT_GE(ok, 2);
  EXPECT_GE(overloaded, 1);
}

// Requests queued or running may hold limits.max_queued_bytes together; a request that
// would pass it gets OVERLOADED with the figures, and nothing is lost.
TEST(ServerFairnessTest, QueuedBytesAreBounded) {
  ServerOptions options = test::TestServerOptions();
  options.threads = 1;
  const std::string jpeg = LargeJpeg(2);
  options.limits.max_message_bytes = static_cast<int64_t>(jpeg.size()) + 1024;
  options.limits.max_queued_bytes = 2 * options.limits.max_message_bytes;  // two at once
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  zmq::context_t context;
  constexpr int kRequests = 6;
  zmq::socket_t socket = SendBurst(&context, server.endpoint, LocaliseJpeg(jpeg), kRequests);
  int ok = 0, overloaded = 0;
  const std::set<uint64_t> ids = CollectReplies(&socket, kRequests, [&](const v1::Reply& reply) {
    if (reply.status() == v1::OK) {
      ++ok;
      EXPECT_NEAR(reply.localise().locations(0).index(), 2, 1);
      return;
    }
    ++overloaded;
    EXPECT_EQ(reply.status(), v1::OVERLOADED) << reply.error();
    EXPECT_NE(reply.error().find("limits.max_queued_bytes"), std::string::npos) << reply.error();
  });
  EXPECT_EQ(static_cast<int>(ids.size()), kRequests);
  EXPECT_GE(ok, 2);
  EXPECT_GE(overloaded, 1);
}

// Requests over 64 KiB are parsed by a worker, not the I/O thread: a valid large localise
// request is answered, and a large message that is not one gets INVALID_ARGUMENT saying why.
TEST(ServerFairnessTest, LargeRequestsAreParsedByWorkers) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  v1::Request big_list;
  big_list.set_request_id(41);
  big_list.mutable_list_maps();
  // Field 15 is unknown to ListMapsRequest's parent: a parser keeps it and moves on.
  std::string bytes = big_list.SerializeAsString();
  const std::string padding(100 << 10, 'x');
  bytes += std::string("\x7a", 1);  // field 15, length-delimited
  for (uint64_t n = padding.size();; n >>= 7) {
    if (n < 0x80) {
      bytes += static_cast<char>(n);
      break;
    }
    bytes += static_cast<char>((n & 0x7F) | 0x80);
  }
  bytes += padding;
  v1::Reply reply = RawCall(server.endpoint, {"", bytes});
  EXPECT_EQ(reply.status(), v1::INVALID_ARGUMENT) << reply.error();
  EXPECT_EQ(reply.request_id(), 41u);
  EXPECT_NE(reply.error().find("only localise requests may be larger"), std::string::npos)
      << reply.error();

  reply = RawCall(server.endpoint, {"", std::string(200 << 10, '\xff')});
  EXPECT_EQ(reply.status(), v1::INVALID_ARGUMENT) << reply.error();

  v1::Request large = LocaliseJpeg(LargeJpeg(7));
  large.set_request_id(42);
  ASSERT_GT(large.ByteSizeLong(), size_t{64} << 10);
  reply = RawCall(server.endpoint, {"", large.SerializeAsString()});
  ASSERT_EQ(reply.status(), v1::OK) << reply.error();
  EXPECT_EQ(reply.request_id(), 42u);
  EXPECT_NEAR(reply.localise().locations(0).index(), 7, 1);
}

// Many connections with one large request each (no per-connection cap applies): once the
// queued work is estimated to pass limits.max_queue_wait_ms, the rest get OVERLOADED at
// once naming it, and a client arriving meanwhile gets its answer (or that refusal) within
// about that wait, not behind the whole flood.
TEST(ServerFairnessTest, QueueWaitIsBounded) {
  ServerOptions options = test::TestServerOptions();
  options.threads = 1;
  options.limits.max_queue_wait_ms = 400;
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  const v1::Request request = LocaliseJpeg(LargeJpeg(6));
  // One request first, so the server knows what a request costs.
  ASSERT_EQ(RawCall(server.endpoint, {"", request.SerializeAsString()}).status(), v1::OK);
  zmq::context_t context;
  constexpr int kConnections = 30;
  std::vector<zmq::socket_t> flood;
  for (int c = 0; c < kConnections; ++c) {
    flood.push_back(SendBurst(&context, server.endpoint, request, 1));
  }
  const auto start = std::chrono::steady_clock::now();
  auto good = MustConnect(server.endpoint);
  const StatusOr<v1::LocaliseReply> answer = good->Localise(kTestMapName, test::TourFeatures(8));
  const double waited_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  EXPECT_TRUE(answer.ok() || answer.status().code() == StatusCode::kResourceExhausted)
      << answer.status().ToString();
  int ok = 0, overloaded = 0;
  for (zmq::socket_t& socket : flood) {
    CollectReplies(&socket, 1, [&](const v1::Reply& reply) {
      if (reply.status() == v1::OK) {
        ++ok;
        return;
      }
      ++overloaded;
      EXPECT_EQ(reply.status(), v1::OVERLOADED) << reply.error();
      EXPECT_NE(reply.error().find("limits.max_queue_wait_ms"), std::string::npos) << reply.error();
    });
  }
  EXPECT_GE(ok, 1);
  EXPECT_GE(overloaded, kConnections / 2);
  // 30 requests of this size take several seconds on one worker; the good client is not
  // behind all of them (generous bound: the estimate is a running mean).
  EXPECT_LT(waited_ms, (4 * options.limits.max_queue_wait_ms + 1000) * test::kTimeScale)
      << waited_ms;
}

// JPEG decodes share limits.max_decode_bytes: a JPEG that could never fit is refused from
// its header with the figures; JPEGs that fit one at a time are all answered (each waits
// for the one before it).
TEST(ServerDecodeBudgetTest, DecodesShareTheMemoryBudget) {
  ServerOptions options = test::TestServerOptions();
  const std::string jpeg = LargeJpeg(4);       // 2400 x 1350 baseline: 9.7 MB to decode
  options.limits.max_decode_bytes = 12 << 20;  // room for one at a time
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  zmq::context_t context;
  constexpr int kRequests = 4;
  zmq::socket_t socket = SendBurst(&context, server.endpoint, LocaliseJpeg(jpeg), kRequests);
  int ok = 0;
  CollectReplies(&socket, kRequests, [&](const v1::Reply& reply) {
    EXPECT_EQ(reply.status(), v1::OK) << reply.error();
    ok += reply.status() == v1::OK;
  });
  EXPECT_EQ(ok, kRequests);

  cv::Mat huge(3000, 3000, CV_8UC3, cv::Scalar(90, 120, 200));
  std::vector<uint8_t> bytes;
  cv::imencode(".jpg", huge, bytes, {cv::IMWRITE_JPEG_PROGRESSIVE, 1});
  const v1::Reply refused =
      RawCall(server.endpoint,
              {"", LocaliseJpeg(std::string(bytes.begin(), bytes.end())).SerializeAsString()});
  EXPECT_EQ(refused.status(), v1::RESOURCE_EXHAUSTED) << refused.error();
  EXPECT_NE(refused.error().find("progressive JPEG needs about 81000000 bytes"), std::string::npos)
      << refused.error();
  EXPECT_NE(refused.error().find("limits.max_decode_bytes"), std::string::npos) << refused.error();
}

// A reply whose client has gone is counted (stats: replies_undelivered), and the server
// serves on: the ROUTER is mandatory, so nothing is dropped without a trace.
TEST(ServerDeliveryTest, RepliesToClientsThatLeftAreCounted) {
  test::TestServer server = test::StartTestServer(test::TestServerOptions());
  ASSERT_NE(server.server, nullptr);
  {
    zmq::context_t context;
    zmq::socket_t gone = SendBurst(&context, server.endpoint, LocaliseJpeg(LargeJpeg(1)), 2);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }  // closed (linger 0) while its requests are being worked on
  auto client = MustConnect(server.endpoint);
  uint64_t undelivered = 0;
  for (const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
       undelivered < 2 && std::chrono::steady_clock::now() < deadline;) {
    auto stats = client->Stats();
    ASSERT_TRUE(stats.ok()) << stats.status().ToString();
    undelivered = stats->replies_undelivered();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_EQ(undelivered, 2u);
  auto served = client->Localise(kTestMapName, test::TourFeatures(2));
  ASSERT_TRUE(served.ok()) << served.status().ToString();
}

// Shutdown with requests queued and running: each gets an answer or UNAVAILABLE, and
// Shutdown returns.
TEST(ServerShutdownTest, InFlightRequestsAreAnsweredOnShutdown) {
  ServerOptions options = test::TestServerOptions();
  options.threads = 1;
  options.queue_capacity = 16;
  test::TestServer server = test::StartTestServer(options);
  ASSERT_NE(server.server, nullptr);
  zmq::context_t context;
  constexpr int kRequests = 6;
  zmq::socket_t socket =
      SendBurst(&context, server.endpoint, LocaliseFeatures(test::TourFeatures(6)), kRequests);
  // Wait until the server has taken them all in (Stats counts requests, and every Stats
  // call so far, this one included), then stop it.
  auto client = MustConnect(server.endpoint);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  for (uint64_t calls = 1;; ++calls) {
    auto stats = client->Stats();
    ASSERT_TRUE(stats.ok());
    if (stats->requests() >= kRequests + calls) break;
    ASSERT_LT(std::chrono::steady_clock::now(), deadline);
  }
  server.server->Shutdown();
  int answered = 0;
  for (int n = 0; n < kRequests; ++n) {
    zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
    if (zmq::poll(&item, 1, std::chrono::seconds(5)) == 0) break;
    std::vector<zmq::message_t> parts;
    ASSERT_TRUE(zmq::recv_multipart(socket, std::back_inserter(parts)));
    v1::Reply reply;
    ASSERT_TRUE(reply.ParseFromArray(parts.back().data(), static_cast<int>(parts.back().size())));
    EXPECT_TRUE(reply.status() == v1::OK || reply.status() == v1::UNAVAILABLE) << reply.error();
    ++answered;
  }
  EXPECT_EQ(answered, kRequests);
}

}  // namespace
}  // namespace sceneloc
