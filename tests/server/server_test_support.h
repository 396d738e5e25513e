// Shared by the server and client tests: one real map trained from a generated tour, its
// tour's JPEGs and features, and a real server on tcp://127.0.0.1:* serving it.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "common/features/feature_set.h"
#include "server/map_registry.h"
#include "server/server.h"
#include "server/server_options.h"

namespace sceneloc::test {

// Whether this build runs under AddressSanitizer (scripts/sanitize.sh). g++ says so with
// __SANITIZE_ADDRESS__; clang 14 only through __has_feature.
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kUnderAsan = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kUnderAsan = true;
#else
inline constexpr bool kUnderAsan = false;
#endif
#else
inline constexpr bool kUnderAsan = false;
#endif

// How many times slower this build runs: 10 under ASan + UBSan, else 1. Tests scale their
// time bounds by it.
inline constexpr int kTimeScale = kUnderAsan ? 10 : 1;

// Name the test map is served under (its file stem).
inline constexpr char kTestMapName[] = "synthetic";
// Locations of the generated tour the test map is trained from.
inline constexpr int kTestTourLocations = 12;

// The map file, trained on first use (12 locations, 640x360, image_scale 1) and cached
// in the build tree: the ctest fixture server/TrainSyntheticMap trains it once per test
// run; a test binary run alone trains it if it is missing or unreadable.
const std::string& TestMapPath();
// Trains the test map into TestMapPath()'s file even when one is there (the fixture).
void TrainTestMapAfresh();
// Folder holding TestMapPath() (a maps directory with that one map).
std::string TestMapsDir();
// JPEG bytes of the training pass, location i at index i.
const std::vector<std::string>& TourJpegs();
// Features of TourJpegs()[i], extracted with the test map's own settings.
const FeatureSet& TourFeatures(int i);

// A registry with the test map loaded and a server on tcp://127.0.0.1:* serving it.
struct TestServer {
  std::unique_ptr<MapRegistry> registry;
  std::unique_ptr<Server> server;
  std::string endpoint;
};
// Options for a test server: endpoint tcp://127.0.0.1:*, maps_dir TestMapsDir(), 2 threads,
// summaries off, log level warn (and a 120 s request budget under ASan).
ServerOptions TestServerOptions();
// Starts a server with `options` (gtest-fatal on failure: check with HasFatalFailure).
TestServer StartTestServer(const ServerOptions& options);
// Starts a server with `options` serving every map file in options.maps_dir.
TestServer StartTestServerOnDir(const ServerOptions& options);

// A fresh maps directory of its own (under the test temp dir) holding a copy of the test
// map as <kTestMapName>.scnl; deleted with everything in it by the destructor.
class TempMapsDir {
 public:
  explicit TempMapsDir(const std::string& tag);
  ~TempMapsDir();
  TempMapsDir(const TempMapsDir&) = delete;
  TempMapsDir& operator=(const TempMapsDir&) = delete;
  const std::string& path() const { return path_; }
  // <path()>/<map>.scnl
  std::string MapPath(const std::string& map = kTestMapName) const;

 private:
  std::string path_;
};

// Writes `bytes` over `path` in place (open, truncate, write, close: not atomic, as a
// careless copy would), so a watcher sees one IN_CLOSE_WRITE.
void WriteInPlace(const std::string& path, const std::string& bytes);
// The whole content of `path` (empty when it cannot be read).
std::string ReadFile(const std::string& path);

}  // namespace sceneloc::test
