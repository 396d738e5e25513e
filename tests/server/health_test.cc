// The liveness and readiness probes (server/health.h): what each requires, and a body that
// says what is missing.
#include "server/health.h"

#include <gtest/gtest.h>

#include <string>

namespace sceneloc {
namespace {

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Draining, a worker without its broker and a silent I/O thread each make the server not
// ready; only the silent I/O thread makes it not alive.
TEST(HealthTest, ProbesSayWhatIsMissing) {
  ServerHealth health;
  health.maps_loaded = 2;
  EXPECT_EQ(Readiness(health).status, 200);
  health.draining = true;
  EXPECT_EQ(Readiness(health).status, 503);
  EXPECT_EQ(Liveness(health).status, 200);
  health.draining = false;
  health.worker_mode = true;
  health.broker = "tcp://broker:5556";
  EXPECT_TRUE(Contains(Readiness(health).body, "tcp://broker:5556"));
  health.broker_connected = true;
  EXPECT_EQ(Readiness(health).status, 200);
  health.io_silence = kMaxIoSilence + std::chrono::seconds(1);
  EXPECT_EQ(Liveness(health).status, 503);
  EXPECT_EQ(Readiness(health).status, 503);
}

// Without a map the server is alive but not ready, and says so; ready says how many maps.
TEST(HealthTest, ReadyNeedsAMap) {
  ServerHealth health;
  EXPECT_EQ(Liveness(health).status, 200);
  const HttpResponse not_ready = Readiness(health);
  EXPECT_EQ(not_ready.status, 503);
  EXPECT_TRUE(Contains(not_ready.body, "no map loaded")) << not_ready.body;
  health.maps_loaded = 3;
  const HttpResponse ready = Readiness(health);
  EXPECT_EQ(ready.status, 200);
  EXPECT_TRUE(Contains(ready.body, "3 map(s) loaded")) << ready.body;
}

// Liveness fails only past kMaxIoSilence, and the body says for how long.
TEST(HealthTest, LivenessToleratesShortSilence) {
  ServerHealth health;
  health.io_silence = kMaxIoSilence - std::chrono::seconds(1);
  EXPECT_EQ(Liveness(health).status, 200);
  health.io_silence = kMaxIoSilence + std::chrono::seconds(5);
  const HttpResponse dead = Liveness(health);
  EXPECT_EQ(dead.status, 503);
  EXPECT_TRUE(Contains(dead.body, "has not woken for")) << dead.body;
}

}  // namespace
}  // namespace sceneloc
