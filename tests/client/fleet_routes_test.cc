// Routes files of a fleet of groups (client/fleet_routes.h): reading maps: and default:,
// choosing each map's endpoint, and one named error for each way a file can be wrong.
#include "client/fleet_routes.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

class FleetRoutesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = (fs::path(::testing::TempDir()) /
             ("fleet_routes_test_" + std::to_string(::getpid()) + "_" + test->name() + ".yaml"))
                .string();
  }
  void TearDown() override { fs::remove(path_); }

  StatusOr<FleetRoutes> Read(const std::string& yaml) const {
    std::ofstream(path_) << yaml;
    return ReadFleetRoutes(path_);
  }
  // Expects the file to be refused as InvalidArgument, naming it and saying `expected`.
  void ExpectRefused(const std::string& yaml, const std::string& expected) const {
    const StatusOr<FleetRoutes> routes = Read(yaml);
    ASSERT_FALSE(routes.ok()) << yaml;
    EXPECT_EQ(routes.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(routes.status().message().find(path_), std::string::npos);
    EXPECT_NE(routes.status().message().find(expected), std::string::npos)
        << routes.status().message();
  }

  std::string path_;
};

// Listed maps go to their broker, others to the default; every endpoint is listed once,
// the default first.
TEST_F(FleetRoutesTest, MapsGoToTheirBrokerElseTheDefault) {
  const StatusOr<FleetRoutes> routes = Read(
      "maps:\n  gardens: tcp://a:1\n  corridor: tcp://b:2\n  hall: tcp://a:1\n"
      "default: tcp://c:3\n");
  ASSERT_TRUE(routes.ok()) << routes.status().ToString();
  EXPECT_EQ(*routes->EndpointOf("corridor"), "tcp://b:2");
  EXPECT_EQ(*routes->EndpointOf("gardens"), "tcp://a:1");
  EXPECT_EQ(*routes->EndpointOf("elsewhere"), "tcp://c:3");
  EXPECT_EQ(routes->Endpoints(), (std::vector<std::string>{"tcp://c:3", "tcp://b:2", "tcp://a:1"}));
}

// Without a default, a map that is not listed is NotFound naming the map and the file.
TEST_F(FleetRoutesTest, UnlistedMapWithoutDefaultIsNotFound) {
  const StatusOr<FleetRoutes> routes = Read("maps:\n  gardens: tcp://a:1\n");
  ASSERT_TRUE(routes.ok());
  const StatusOr<std::string> endpoint = routes->EndpointOf("corridor");
  EXPECT_EQ(endpoint.status().code(), StatusCode::kNotFound);
  EXPECT_NE(endpoint.status().message().find("'corridor'"), std::string::npos);
  EXPECT_NE(endpoint.status().message().find(path_), std::string::npos);
}

// A default alone is a fleet of one group.
TEST_F(FleetRoutesTest, DefaultAloneIsEnough) {
  const StatusOr<FleetRoutes> routes = Read("default: tcp://c:3\n");
  ASSERT_TRUE(routes.ok());
  EXPECT_EQ(*routes->EndpointOf("any"), "tcp://c:3");
  EXPECT_EQ(routes->Endpoints(), std::vector<std::string>{"tcp://c:3"});
}

// Each way a routes file can be wrong is refused, saying what is wrong.
TEST_F(FleetRoutesTest, RefusesMalformedFiles) {
  ExpectRefused("maps: [unclosed\n", "not valid YAML");
  ExpectRefused("- a\n- b\n", "expected keys maps: and default:");
  ExpectRefused("mapz:\n  first: tcp://a:1\n", "unknown key 'mapz'");
  ExpectRefused("maps: tcp://a:1\n", "maps: must map each map name to an endpoint");
  ExpectRefused("maps:\n  first: \"\"\n", "map 'first' has no endpoint");
  ExpectRefused("default: [a, b]\n", "default: must be an endpoint");
  ExpectRefused("default: \"\"\n", "default: is empty");
  ExpectRefused("maps: {}\n", "no routes");
}

// A file that does not exist is NotFound.
TEST(FleetRoutesFileTest, MissingFileIsNotFound) {
  EXPECT_EQ(ReadFleetRoutes("/nonexistent/routes.yaml").status().code(), StatusCode::kNotFound);
}

}  // namespace
}  // namespace sceneloc
