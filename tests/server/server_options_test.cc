// The server's settings: the shipped file, strictness, and flags over the file.
#include "server/server_options.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "common/config/settings_table.h"

namespace sceneloc {
namespace {

const ServerFlag& Flag(const std::string& name) {
  static const std::vector<ServerFlag> flags = ServerFlags();
  const auto it =
      std::find_if(flags.begin(), flags.end(), [&](const ServerFlag& f) { return f.flag == name; });
  EXPECT_NE(it, flags.end()) << name;
  return *it;
}

// configs/server.yaml loads and holds the documented defaults.
TEST(ServerOptionsTest, ShippedFileLoads) {
  ServerOptions options;
  ASSERT_TRUE(LoadServerOptions(SCENELOC_CONFIGS_DIR "/server.yaml", &options).ok());
  EXPECT_EQ(options.endpoint, "tcp://*:5555");
  EXPECT_EQ(options.threads, 2);
  EXPECT_EQ(options.limits.max_keypoints, 8192);
  EXPECT_TRUE(options.watch_maps);
  EXPECT_EQ(options.reload_debounce_ms, 100);
  EXPECT_EQ(options.matching.verify_top, MatchOptions().verify_top);
}

// Unknown sections and keys, wrong types and out-of-range values are errors naming the
// key, and leave the options untouched.
TEST(ServerOptionsTest, StrictAboutKeysTypesAndRanges) {
  ServerOptions options;
  const Status unknown = ParseServerOptions("server:\n  thread: 3\n", "f", &options);
  EXPECT_NE(unknown.message().find("server.thread"), std::string::npos) << unknown.message();
  EXPECT_FALSE(ParseServerOptions("serverz:\n  threads: 3\n", "f", &options).ok());
  EXPECT_FALSE(ParseServerOptions("server:\n  threads: many\n", "f", &options).ok());
  EXPECT_FALSE(ParseServerOptions("server:\n  threads: 0\n", "f", &options).ok());
  EXPECT_FALSE(ParseServerOptions("server:\n  log_level: loud\n", "f", &options).ok());
  EXPECT_FALSE(ParseServerOptions("matching:\n  s_mim: 0.2\n", "f", &options).ok());
  EXPECT_FALSE(ParseServerOptions("limits:\n  max_keypoints: -1\n", "f", &options).ok());
  EXPECT_EQ(options.threads, ServerOptions().threads);
  ASSERT_TRUE(
      ParseServerOptions("matching:\n  s_min: 0.25\nlimits:\n  max_top_k: 7\n", "f", &options)
          .ok());
  EXPECT_EQ(options.matching.s_min, 0.25);
  EXPECT_EQ(options.limits.max_top_k, 7);
}

// Every field has a flag; flags apply with the file's checks.
TEST(ServerOptionsTest, FlagsOverrideWithTheSameChecks) {
  ServerOptions options;
  ASSERT_TRUE(ApplyServerFlag(Flag("maps"), "/srv/maps", &options).ok());
  ASSERT_TRUE(ApplyServerFlag(Flag("threads"), "4", &options).ok());
  ASSERT_TRUE(ApplyServerFlag(Flag("s-min"), "0.4", &options).ok());
  ASSERT_TRUE(ApplyServerFlag(Flag("use-neighbourhood"), "false", &options).ok());
  ASSERT_TRUE(ApplyServerFlag(Flag("max-message-bytes"), "1048576", &options).ok());
  ASSERT_TRUE(ApplyServerFlag(Flag("watch-maps"), "false", &options).ok());
  EXPECT_FALSE(ApplyServerFlag(Flag("reload-debounce-ms"), "-1", &options).ok());
  EXPECT_EQ(options.maps_dir, "/srv/maps");
  EXPECT_EQ(options.threads, 4);
  EXPECT_EQ(options.matching.s_min, 0.4);
  EXPECT_FALSE(options.matching.use_neighbourhood);
  EXPECT_EQ(options.limits.max_message_bytes, 1048576);
  EXPECT_FALSE(options.watch_maps);
  EXPECT_EQ(options.reload_debounce_ms, 100);
  const Status bad = ApplyServerFlag(Flag("threads"), "0", &options);
  EXPECT_NE(bad.message().find("--threads"), std::string::npos) << bad.message();
  EXPECT_FALSE(ApplyServerFlag(Flag("s-min"), "2", &options).ok());
  EXPECT_EQ(options.threads, 4);
  // Round trip through the YAML the server logs.
  ServerOptions again;
  ASSERT_TRUE(ParseServerOptions(ServerOptionsToYaml(options), "yaml", &again).ok());
  EXPECT_EQ(again.maps_dir, "/srv/maps");
  EXPECT_EQ(again.matching.s_min, 0.4);
  // One flag per field: 24 server and limits fields, 3 auth fields, 3 sessions fields, 4
  // keep_frames fields, the 19 of the sequence filter and every matching field.
  const std::vector<ServerFlag> flags = ServerFlags();
  const auto matching = std::count_if(flags.begin(), flags.end(),
                                      [](const ServerFlag& f) { return f.section == "matching"; });
  const auto sequence = std::count_if(flags.begin(), flags.end(),
                                      [](const ServerFlag& f) { return f.section == "sequence"; });
  EXPECT_EQ(sequence, 19);
  EXPECT_EQ(flags.size() - static_cast<size_t>(matching + sequence), 34u);
  ASSERT_TRUE(ApplyServerFlag(Flag("keep-frames"), "/var/lib/sceneloc/kept", &options).ok());
  EXPECT_EQ(options.keep_frames.dir, "/var/lib/sceneloc/kept");
  EXPECT_FALSE(ApplyServerFlag(Flag("keep-frames-after"), "0", &options).ok());
  ASSERT_TRUE(ApplyServerFlag(Flag("sequence-evidence-weight"), "0.7", &options).ok());
  EXPECT_EQ(options.matching.sequence.evidence_weight, 0.7);
  EXPECT_FALSE(ApplyServerFlag(Flag("sequence-evidence-weight"), "0", &options).ok());
  EXPECT_FALSE(ApplyServerFlag(Flag("sequence-jump"), "1.5", &options).ok());
  ASSERT_TRUE(ApplyServerFlag(Flag("sequence-learn-camera-scale"), "false", &options).ok());
  EXPECT_FALSE(options.matching.sequence.learn_camera_scale);
  EXPECT_FALSE(ApplyServerFlag(Flag("sequence-camera-min-inliers"), "0", &options).ok());
  ASSERT_TRUE(ApplyServerFlag(Flag("max-sessions"), "50", &options).ok());
  EXPECT_EQ(options.sessions.max_sessions, 50);
  EXPECT_FALSE(ApplyServerFlag(Flag("max-sessions"), "0", &options).ok());
  EXPECT_FALSE(ApplyServerFlag(Flag("session-idle-timeout"), "0", &options).ok());
  ASSERT_TRUE(ApplyServerFlag(Flag("max-map-bytes"), "1048576", &options).ok());
  EXPECT_EQ(options.limits.max_map_bytes, 1048576);
  EXPECT_FALSE(ApplyServerFlag(Flag("max-map-bytes"), "10", &options).ok());
  EXPECT_GE(matching, 10);
}

// configs/server.yaml is exactly what the declarations print for the defaults
// (regenerate: sceneloc-server --print-config > configs/server.yaml).
TEST(ServerOptionsTest, DocumentedConfigMatchesTheDeclarations) {
  const StatusOr<std::string> text = ReadSettingsFile(SCENELOC_CONFIGS_DIR "/server.yaml");
  ASSERT_TRUE(text.ok());
  EXPECT_EQ(*text, DocumentedServerSettings());
}

// Every flag's help names what it accepts, from the same declaration as the file's checks.
TEST(ServerOptionsTest, FlagHelpNamesTheRange) {
  const std::vector<ServerFlag> flags = ServerFlags();
  const auto threads = std::find_if(flags.begin(), flags.end(),
                                    [](const ServerFlag& f) { return f.flag == "threads"; });
  ASSERT_NE(threads, flags.end());
  EXPECT_NE(threads->help.find("[1, 256]"), std::string::npos) << threads->help;
  const auto level = std::find_if(flags.begin(), flags.end(),
                                  [](const ServerFlag& f) { return f.flag == "log-level"; });
  ASSERT_NE(level, flags.end());
  EXPECT_NE(level->help.find("trace | debug"), std::string::npos) << level->help;
}

}  // namespace
}  // namespace sceneloc
