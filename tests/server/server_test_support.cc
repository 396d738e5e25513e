#include "tests/server/server_test_support.h"

#include <gtest/gtest.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <mutex>

#include "common/features/extractor.h"
#include "common/map/map_io.h"
#include "common/synthetic/tour_generator.h"
#include "common/training/trainer.h"

namespace sceneloc::test {
namespace {

namespace fs = std::filesystem;

TourOptions TestTour() {
  TourOptions tour;
  tour.num_locations = kTestTourLocations;
  return tour;
}

// Trains the test map into `path` (atomically: concurrent trainers are harmless).
void TrainTestMap(const std::string& path) {
  const fs::path tour_dir =
      fs::path(::testing::TempDir()) / ("sceneloc_server_tour_" + std::to_string(::getpid()));
  fs::remove_all(tour_dir);
  Status written = WriteTour(TestTour(), tour_dir.string(), kTrainingPass);
  if (!written.ok()) std::abort();
  TrainOptions options;
  options.extractor.working_size = 640;  // the generated frames are already small
  auto trained = TrainFromFolder(tour_dir.string(), options, 2, nullptr);
  fs::remove_all(tour_dir);
  if (!trained.ok() || !SaveMap(trained->map, path).ok()) {
    std::fprintf(stderr, "cannot train the test map: %s\n", trained.status().ToString().c_str());
    std::abort();
  }
}

std::string MapFile() {
  fs::create_directories(SCENELOC_TEST_DATA_DIR);
  return std::string(SCENELOC_TEST_DATA_DIR) + "/" + kTestMapName + ".scnl";
}

}  // namespace

const std::string& TestMapPath() {
  static const std::string path = [] {
    const std::string p = MapFile();
    if (!fs::exists(p) || !LoadMap(p).ok()) TrainTestMap(p);
    return p;
  }();
  return path;
}

void TrainTestMapAfresh() { TrainTestMap(MapFile()); }

std::string TestMapsDir() { return fs::path(TestMapPath()).parent_path().string(); }

const std::vector<std::string>& TourJpegs() {
  static const std::vector<std::string> jpegs = [] {
    auto rendered = RenderTourJpegs(TestTour(), kTrainingPass);
    if (!rendered.ok()) std::abort();
    return std::move(rendered).value();
  }();
  return jpegs;
}

const FeatureSet& TourFeatures(int i) {
  static std::mutex mutex;
  static std::vector<std::unique_ptr<FeatureSet>> cache(kTestTourLocations);
  std::lock_guard<std::mutex> lock(mutex);
  auto& slot = cache.at(static_cast<size_t>(i));
  if (slot == nullptr) {
    auto map = LoadMap(TestMapPath());
    auto image = DecodeImage(TourJpegs().at(static_cast<size_t>(i)), 4096);
    if (!map.ok() || !image.ok()) std::abort();
    auto features = FeatureExtractor::Create(map->options.extractor)
                        ->Extract(*image, map->QueryTarget(image->cols, image->rows));
    if (!features.ok()) std::abort();
    slot = std::make_unique<FeatureSet>(std::move(features).value());
  }
  return *slot;
}

ServerOptions TestServerOptions() {
  ServerOptions options;
  options.endpoint = "tcp://127.0.0.1:*";
  options.maps_dir = TestMapsDir();
  options.threads = 2;
  options.summary_interval_s = 0;
  options.log_level = "warn";
  if (kUnderAsan) {
    // Under ASan + UBSan (scripts/sanitize.sh) requests run 10-20x slower; the default 5 s
    // budget would turn slowness into DEADLINE_EXCEEDED, and the 1 s queue wait into
    // OVERLOADED. Tests of the deadline set their own.
    options.limits.max_request_ms = 120000;
    options.limits.max_queue_wait_ms = 120000;
  }
  return options;
}

namespace {

// A registry made with the server's own self-test settings, filled by `load`, then a server
// started on it. Failures are test failures; t.server stays null when the start failed.
template <typename LoadFn>
TestServer StartWithRegistry(const ServerOptions& options, LoadFn load) {
  spdlog::set_level(spdlog::level::warn);
  TestServer t;
  MapRegistry::Options registry_options;
  registry_options.self_test = options.matching;
  t.registry = std::make_unique<MapRegistry>(registry_options);
  load(t.registry.get());
  auto server = Server::Start(options, t.registry.get());
  EXPECT_TRUE(server.ok()) << server.status().ToString();
  if (!server.ok()) return t;
  t.server = std::move(server).value();
  t.endpoint = t.server->endpoint();
  return t;
}

}  // namespace

TestServer StartTestServer(const ServerOptions& options) {
  return StartWithRegistry(options, [](MapRegistry* registry) {
    auto loaded = registry->Load(TestMapPath());
    EXPECT_TRUE(loaded.ok()) << loaded.status().ToString();
  });
}

TestServer StartTestServerOnDir(const ServerOptions& options) {
  return StartWithRegistry(options, [&](MapRegistry* registry) {
    std::vector<Status> failures;
    EXPECT_TRUE(registry->LoadDirectory(options.maps_dir, &failures).ok());
    EXPECT_TRUE(failures.empty()) << failures.front().ToString();
  });
}

TempMapsDir::TempMapsDir(const std::string& tag) {
  static int count = 0;
  path_ = (fs::path(::testing::TempDir()) /
           ("sceneloc_" + tag + "_" + std::to_string(::getpid()) + "_" + std::to_string(++count)))
              .string();
  fs::remove_all(path_);
  fs::create_directories(path_);
  fs::copy_file(TestMapPath(), MapPath());
}

TempMapsDir::~TempMapsDir() {
  std::error_code ignored;
  fs::remove_all(path_, ignored);
}

std::string TempMapsDir::MapPath(const std::string& map) const {
  return (fs::path(path_) / (map + kMapFileExtension)).string();
}

void WriteInPlace(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace sceneloc::test
