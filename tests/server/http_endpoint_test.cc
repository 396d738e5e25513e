// The operator endpoint's HTTP server (server/http_endpoint.h) over real HTTP on loopback:
// GET on known paths only, handler errors as 500, the chosen port, stopping, and the
// addresses it accepts.
#include "server/http_endpoint.h"

#include <gtest/gtest.h>

#include <map>
#include <stdexcept>
#include <string>

#include "tests/server/http_test_client.h"

namespace sceneloc {
namespace {

using test::Http;
using test::HttpResult;

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// GET on a known path runs its handler; another method is 405, an unknown path 404 listing
// the known ones, a handler that throws 500 with its message; after Stop nothing answers.
TEST(HttpEndpointTest, ServesGetOnItsPathsOnly) {
  std::map<std::string, HttpEndpoint::Handler> handlers;
  handlers["/ok"] = [] { return HttpResponse{200, "text/plain", "fine"}; };
  handlers["/throws"] = []() -> HttpResponse { throw std::runtime_error("handler broke"); };
  auto endpoint = HttpEndpoint::Start("127.0.0.1:0", handlers);
  ASSERT_TRUE(endpoint.ok()) << endpoint.status().ToString();
  const std::string address = (*endpoint)->address();
  EXPECT_NE(address, "127.0.0.1:0");
  const HttpResult ok = Http(address, "GET", "/ok");
  EXPECT_EQ(ok.status, 200);
  EXPECT_EQ(ok.body, "fine");
  EXPECT_EQ(Http(address, "POST", "/ok").status, 405);
  const HttpResult missing = Http(address, "GET", "/nothing-here");
  EXPECT_EQ(missing.status, 404);
  EXPECT_TRUE(Contains(missing.body, "/ok")) << missing.body;  // says what is served
  const HttpResult broken = Http(address, "GET", "/throws");
  EXPECT_EQ(broken.status, 500);
  EXPECT_TRUE(Contains(broken.body, "handler broke"));
  (*endpoint)->Stop();
  EXPECT_EQ(Http(address, "GET", "/ok").status, 0);  // nothing listens any more
}

// HOST:PORT with a port in 0..65535 is an address; anything else is InvalidArgument.
TEST(HttpEndpointTest, ValidatesAddresses) {
  for (const char* good : {"127.0.0.1:0", "0.0.0.0:9464", "localhost:65535"}) {
    EXPECT_TRUE(ValidateHttpAddress(good).ok()) << good;
  }
  for (const char* bad : {"", "9464", "127.0.0.1:", "127.0.0.1:65536", "127.0.0.1:port", ":80"}) {
    EXPECT_EQ(ValidateHttpAddress(bad).code(), StatusCode::kInvalidArgument) << bad;
  }
}

// A malformed address is refused by Start before anything listens.
TEST(HttpEndpointTest, StartRefusesAMalformedAddress) {
  const auto endpoint = HttpEndpoint::Start("127.0.0.1:99999", {});
  EXPECT_EQ(endpoint.status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace sceneloc
