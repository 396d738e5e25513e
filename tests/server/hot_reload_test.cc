// Hot reload of a serving server through real sockets: map files replaced, broken, added
// and deleted in the watched folder while clients keep sending requests.
#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>
#include <zmq.hpp>
#include <zmq_addon.hpp>

#include "client/client.h"
#include "common/map/map_io.h"
#include "common/synthetic/tour_generator.h"
#include "common/training/extend.h"
#include "tests/server/server_call_support.h"
#include "tests/server/server_test_support.h"
#include "tests/support/tour_features.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using test::kTestMapName;
using test::kTestTourLocations;
using test::MustConnect;
constexpr std::chrono::seconds kWait(20);

// Clients on their own threads sending feature-set localise requests back to back until
// stopped, checking every answer and recording the map generation each reply names.
class Load {
 public:
  Load(const std::string& endpoint, int clients)
      : seen_(static_cast<size_t>(clients)), orders_(static_cast<size_t>(clients)) {
    for (int i = 0; i < kTestTourLocations; ++i) (void)test::TourFeatures(i);  // cached now
    for (int c = 0; c < clients; ++c) {
      threads_.emplace_back([this, endpoint, c] { Run(endpoint, c); });
    }
  }
  ~Load() { Stop(); }

  void Stop() {
    stop_ = true;
    for (std::thread& t : threads_) {
      if (t.joinable()) t.join();
    }
  }

  // Waits until every client has had `n` answers naming `generation`. False at the
  // deadline.
  bool WaitForReplies(uint64_t generation, int n) {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, kWait, [&] {
      for (size_t c = 0; c < seen_.size(); ++c) {
        if (seen_[c].count(generation) == 0 || seen_[c][generation] < n) return false;
      }
      return true;
    });
  }

  int failures() const { return failures_; }
  int ok() const { return ok_; }
  std::string first_failure() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return first_failure_;
  }
  // Generations each client saw, in order of first sight.
  std::vector<std::vector<uint64_t>> orders() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return orders_;
  }

 private:
  void Run(const std::string& endpoint, int c) {
    auto client = MustConnect(endpoint);
    for (int r = 0; client != nullptr && !stop_; ++r) {
      const int i = (c * 5 + r) % kTestTourLocations;
      auto reply = client->Localise(kTestMapName, test::TourFeatures(i));
      std::lock_guard<std::mutex> lock(mutex_);
      if (!reply.ok() || reply->locations().empty() || reply->locations(0).index() != i) {
        ++failures_;
        if (first_failure_.empty()) {
          first_failure_ = reply.ok() ? "wrong location" : reply.status().ToString();
        }
        continue;
      }
      ++ok_;
      const uint64_t g = reply->map().generation();
      auto& order = orders_[static_cast<size_t>(c)];
      if (order.empty() || order.back() != g) order.push_back(g);
      ++seen_[static_cast<size_t>(c)][g];
      cv_.notify_all();
    }
  }

  std::atomic<bool> stop_{false};
  std::atomic<int> failures_{0}, ok_{0};
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<std::map<uint64_t, int>> seen_;  // client -> generation -> answers
  std::vector<std::vector<uint64_t>> orders_;
  std::string first_failure_;
  std::vector<std::thread> threads_;  // last: the threads use everything above
};

class HotReloadTest : public ::testing::Test {
 protected:
  void SetUp() override { Start(test::TestServerOptions()); }

  void Start(ServerOptions options) {
    options.maps_dir = dir_.path();
    options.reload_debounce_ms = 20;
    server_ = test::StartTestServerOnDir(options);
    ASSERT_NE(server_.server, nullptr);
    client_ = MustConnect(server_.endpoint);
    ASSERT_NE(client_, nullptr);
  }

  uint64_t LoadFailures() {
    auto stats = client_->Stats();
    EXPECT_TRUE(stats.ok());
    return stats.ok() ? stats->map_load_failures() : 0;
  }

  test::TempMapsDir dir_{"hot_reload"};
  test::TestServer server_;
  std::unique_ptr<Client> client_;
};

// The map file replaced atomically (SaveMap: temporary file + rename) under load from 4
// clients: no request fails, and once the new map is in every client's replies name its
// generation and checksum; the temporary file never becomes a map.
TEST_F(HotReloadTest, AtomicReplaceUnderLoadFailsNoRequest) {
  Load load(server_.endpoint, 4);
  ASSERT_TRUE(load.WaitForReplies(1, 2)) << load.first_failure();

  auto map = LoadMap(test::TestMapPath());
  ASSERT_TRUE(map.ok());
  map->provenance.tour_dir += "-replaced";
  MapFileInfo info;
  ASSERT_TRUE(SaveMap(*map, dir_.MapPath(), &info).ok());
  EXPECT_TRUE(load.WaitForReplies(2, 3)) << "replies never named generation 2";
  load.Stop();

  EXPECT_EQ(load.failures(), 0) << load.first_failure();
  for (const auto& order : load.orders()) {
    EXPECT_EQ(order, (std::vector<uint64_t>{1, 2}));  // never back to the old map
  }
  auto maps = client_->ListMaps();
  ASSERT_TRUE(maps.ok());
  ASSERT_EQ(maps->maps_size(), 1);
  EXPECT_EQ(maps->maps(0).version().generation(), 2u);
  EXPECT_EQ(maps->maps(0).version().checksum(), info.checksum);
  auto stats = client_->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->map_loads(), 2u);
  EXPECT_EQ(stats->map_load_failures(), 0u);
  EXPECT_EQ(stats->replies_by_status().count("INTERNAL"), 0u);
}

// Garbage, then a truncated map, written in place over the served file under load: both
// fail to load and are counted, the old generation keeps answering, no request fails; a
// ReloadMap of the bad file returns the load error to the admin caller.
TEST_F(HotReloadTest, CorruptAndTruncatedFilesKeepTheOldMapServing) {
  Load load(server_.endpoint, 4);
  ASSERT_TRUE(load.WaitForReplies(1, 1)) << load.first_failure();
  const std::string good = test::ReadFile(dir_.MapPath());

  test::WriteInPlace(dir_.MapPath(), std::string(4096, '\x5a'));
  ASSERT_TRUE(server_.server->WaitForLoader(kWait));
  EXPECT_EQ(LoadFailures(), 1u);
  auto reload = client_->Reload(kTestMapName);
  EXPECT_FALSE(reload.ok());
  EXPECT_NE(reload.status().message().find(dir_.MapPath()), std::string::npos)
      << reload.status().ToString();
  EXPECT_EQ(LoadFailures(), 2u);

  test::WriteInPlace(dir_.MapPath(), good.substr(0, good.size() * 2 / 3));
  ASSERT_TRUE(server_.server->WaitForLoader(kWait));
  EXPECT_EQ(LoadFailures(), 3u);
  ASSERT_TRUE(load.WaitForReplies(1, 3));
  load.Stop();

  EXPECT_EQ(load.failures(), 0) << load.first_failure();
  for (const auto& order : load.orders()) EXPECT_EQ(order, (std::vector<uint64_t>{1}));
  auto maps = client_->ListMaps();
  ASSERT_TRUE(maps.ok());
  ASSERT_EQ(maps->maps_size(), 1);
  EXPECT_EQ(maps->maps(0).version().generation(), 1u);
}

// A map file copied into the folder is served under its stem, with generation 1.
TEST_F(HotReloadTest, NewFileBecomesANewMap) {
  fs::copy_file(dir_.MapPath(), dir_.MapPath("annex"));
  ASSERT_TRUE(server_.server->WaitForLoader(kWait));
  auto maps = client_->ListMaps();
  ASSERT_TRUE(maps.ok());
  ASSERT_EQ(maps->maps_size(), 2);
  EXPECT_EQ(maps->maps(0).version().name(), "annex");
  EXPECT_EQ(maps->maps(0).version().generation(), 1u);
  auto reply = client_->Localise("annex", test::TourFeatures(4));
  ASSERT_TRUE(reply.ok()) << reply.status().ToString();
  EXPECT_EQ(reply->locations(0).index(), 4);
  EXPECT_EQ(reply->map().name(), "annex");
}

// The map replaced under load by itself extended with a walk of another street as new ground
// (sceneloc-train --extend --new-ground): no request fails, the new generation answers the
// new street's JPEGs with its new places (after the route's) and the route's with the route's.
TEST_F(HotReloadTest, AnExtendedMapIsReloadedAndAnswersWithPlaces) {
  Load load(server_.endpoint, 2);
  ASSERT_TRUE(load.WaitForReplies(1, 1)) << load.first_failure();
  auto map = LoadMap(test::TestMapPath());
  ASSERT_TRUE(map.ok());
  TourOptions street;
  street.num_locations = kTestTourLocations;
  street.seed = 7;
  const ExtractionTarget frame = map->QueryTarget(street.image_width, street.image_height);
  const std::vector<FeatureSet> walk =
      test::ExtractTourPass(street, kTrainingPass, map->options.extractor, &frame);
  std::vector<std::string> names;
  for (int i = 0; i < kTestTourLocations; ++i) names.push_back("street7_" + TourImageName(i));
  ExtendOptions options;
  options.name = "street 7";
  options.new_ground = true;
  auto extended = ExtendMap(*map, TourInMemory(walk), names, options, 1, nullptr);
  ASSERT_TRUE(extended.ok()) << extended.status().ToString();
  ASSERT_TRUE(SaveMap(extended->map, dir_.MapPath()).ok());
  EXPECT_TRUE(load.WaitForReplies(2, 2)) << "replies never named generation 2";
  load.Stop();
  EXPECT_EQ(load.failures(), 0) << load.first_failure();

  auto jpegs = RenderTourJpegs(street, kTrainingPass);
  ASSERT_TRUE(jpegs.ok());
  for (const int i : {2, 8}) {
    auto reply = client_->Localise(kTestMapName, (*jpegs)[static_cast<size_t>(i)]);
    ASSERT_TRUE(reply.ok()) << reply.status().ToString();
    EXPECT_EQ(reply->map().generation(), 2u);
    EXPECT_NEAR(reply->locations(0).index(), kTestTourLocations + i, 1);
    EXPECT_EQ(reply->locations(0).image_name().rfind("street7_", 0), 0u)
        << reply->locations(0).image_name();
    auto route = client_->Localise(kTestMapName, test::TourJpegs()[static_cast<size_t>(i)]);
    ASSERT_TRUE(route.ok()) << route.status().ToString();
    EXPECT_EQ(route->locations(0).index(), i);
  }
  auto maps = client_->ListMaps();
  ASSERT_TRUE(maps.ok());
  EXPECT_EQ(maps->maps(0).num_locations(), 2 * kTestTourLocations);
}

// A JPEG of tour location `i` scaled up to `width` pixels wide: slow to extract.
std::string LargeJpeg(int i, int width) {
  const std::string& small = test::TourJpegs()[static_cast<size_t>(i)];
  const cv::Mat image = cv::imdecode(
      cv::Mat(1, static_cast<int>(small.size()), CV_8U, const_cast<char*>(small.data())),
      cv::IMREAD_COLOR);
  cv::Mat large;
  cv::resize(image, large, cv::Size(width, width * image.rows / image.cols));
  std::vector<uchar> bytes;
  cv::imencode(".jpg", large, bytes);
  return std::string(bytes.begin(), bytes.end());
}

// Deleting the file unloads the map: later requests get NOT_FOUND, while a request that
// took its snapshot before the delete (a slow, large JPEG) still completes on it.
TEST_F(HotReloadTest, DeletedFileUnloadsAfterInFlightRequestsFinish) {
  zmq::context_t context;
  zmq::socket_t socket(context, zmq::socket_type::dealer);
  socket.set(zmq::sockopt::linger, 0);
  socket.connect(server_.endpoint);
  v1::Request request;
  request.set_request_id(77);
  request.mutable_localise()->set_map(kTestMapName);
  request.mutable_localise()->set_jpeg(LargeJpeg(5, 1920));
  socket.send(zmq::message_t(), zmq::send_flags::sndmore);
  socket.send(zmq::buffer(request.SerializeAsString()), zmq::send_flags::none);
  // Once the server holds it (Stats counts it, with the Stats request itself), a free
  // worker has taken it and its map snapshot.
  for (const auto deadline = Clock::now() + kWait;;) {
    auto stats = client_->Stats();
    ASSERT_TRUE(stats.ok());
    if (stats->in_flight() >= 2) break;
    ASSERT_LT(Clock::now(), deadline);
  }

  fs::remove(dir_.MapPath());
  ASSERT_TRUE(server_.server->WaitForLoader(kWait));
  zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
  const bool answered_before_unload = zmq::poll(&item, 1, std::chrono::milliseconds(0)) > 0;
  auto after = client_->Localise(kTestMapName, test::TourFeatures(1));
  EXPECT_EQ(after.status().code(), StatusCode::kNotFound) << after.status().ToString();
  auto maps = client_->ListMaps();
  ASSERT_TRUE(maps.ok());
  EXPECT_EQ(maps->maps_size(), 0);
  auto stats = client_->Stats();
  ASSERT_TRUE(stats.ok());
  EXPECT_EQ(stats->map_unloads(), 1u);

  ASSERT_GT(zmq::poll(&item, 1, kWait), 0) << "the in-flight request was never answered";
  std::vector<zmq::message_t> parts;
  ASSERT_TRUE(zmq::recv_multipart(socket, std::back_inserter(parts)));
  v1::Reply reply;
  ASSERT_TRUE(reply.ParseFromArray(parts.back().data(), static_cast<int>(parts.back().size())));
  EXPECT_EQ(reply.request_id(), 77u);
  ASSERT_EQ(reply.status(), v1::OK) << reply.error();
  EXPECT_EQ(reply.localise().map().generation(), 1u);
  EXPECT_FALSE(reply.localise().locations().empty());
  // Otherwise the request did not overlap the unload and this test proved nothing.
  EXPECT_FALSE(answered_before_unload)
      << "the request finished before the unload: " << reply.localise().timings().total_ms()
      << " ms";
}

// ReloadMap runs on the loader thread, not a worker: with the one worker busy on a slow
// request, a reload is answered (OK, the next generation) before that request finishes,
// where a reload queued for the worker would wait behind it.
TEST(HotReloadBusyTest, ReloadIsAnsweredWhileEveryWorkerIsBusy) {
  test::TempMapsDir dir("reload_busy");
  ServerOptions options = test::TestServerOptions();
  options.maps_dir = dir.path();
  options.threads = 1;
  test::TestServer server = test::StartTestServerOnDir(options);
  ASSERT_NE(server.server, nullptr);
  auto client = MustConnect(server.endpoint);
  ASSERT_NE(client, nullptr);

  zmq::context_t context;
  zmq::socket_t socket(context, zmq::socket_type::dealer);
  socket.set(zmq::sockopt::linger, 0);
  socket.connect(server.endpoint);
  v1::Request slow;
  slow.set_request_id(1);
  slow.mutable_localise()->set_map(kTestMapName);
  slow.mutable_localise()->set_jpeg(LargeJpeg(2, 1920));
  socket.send(zmq::message_t(), zmq::send_flags::sndmore);
  socket.send(zmq::buffer(slow.SerializeAsString()), zmq::send_flags::none);
  // Held by the server (with the Stats request itself): the worker has it, or has it next.
  for (const auto deadline = Clock::now() + kWait;;) {
    auto stats = client->Stats();
    ASSERT_TRUE(stats.ok());
    if (stats->in_flight() >= 2) break;
    ASSERT_LT(Clock::now(), deadline);
  }

  auto reloaded = client->Reload(kTestMapName);
  ASSERT_TRUE(reloaded.ok()) << reloaded.status().ToString();
  EXPECT_EQ(reloaded->map().version().generation(), 2u);
  zmq::pollitem_t item{socket.handle(), 0, ZMQ_POLLIN, 0};
  EXPECT_EQ(zmq::poll(&item, 1, std::chrono::milliseconds(0)), 0)
      << "the slow request was answered before the reload";
  ASSERT_GT(zmq::poll(&item, 1, kWait), 0);
  std::vector<zmq::message_t> parts;
  ASSERT_TRUE(zmq::recv_multipart(socket, std::back_inserter(parts)));
  v1::Reply reply;
  ASSERT_TRUE(reply.ParseFromArray(parts.back().data(), static_cast<int>(parts.back().size())));
  EXPECT_EQ(reply.status(), v1::OK) << reply.error();
  EXPECT_EQ(reply.localise().map().generation(), 1u);  // its snapshot, taken before the swap
}

}  // namespace
}  // namespace sceneloc
