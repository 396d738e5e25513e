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
// summaries off, log level warn.
ServerOptions TestServerOptions();
// Starts a server with `options` (gtest-fatal on failure: check with HasFatalFailure).
TestServer StartTestServer(const ServerOptions& options);

}  // namespace sceneloc::test
