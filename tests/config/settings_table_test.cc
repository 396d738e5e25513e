// The YAML side of the settings tables (common/config/settings_table.h) on a table of its
// own: what a file may set and the error for each way it can be wrong, a command-line
// value, the YAML and documented text of the values, and reading a settings file.
#include "common/config/settings_table.h"

#include <gtest/gtest.h>

#include <string>

#include "tests/support/scratch_dir.h"

namespace sceneloc {
namespace {

struct Robot {
  int wheels = 4;
  double speed = 1.5;
  int64_t memory = 1 << 20;
  bool lights = false;
  std::string drive = "diff";
  std::string label = "r2";
  int camera_cols = 0;
};

SettingTable RobotSettings(Robot* r) {
  return {
      Setting("body", "wheels", &r->wheels).Range(2, 8).Help("wheels on the ground"),
      Setting("body", "speed", &r->speed).Range(0, 3).Unit("m/s"),
      Setting("body", "memory", &r->memory).Range(1024, 1e13).Unit("bytes"),
      Setting("body", "lights", &r->lights).Help("headlights on"),
      Setting("drive", "drive", &r->drive).Choices({"diff", "ackermann"}),
      Setting("drive", "label", &r->label),
      Setting("drive", "camera_cols", &r->camera_cols).Range(4, 64).Off(0),
  };
}

// Applies `yaml` to `r`; the status message, empty on success.
std::string Apply(const std::string& yaml, Robot* r) {
  const Status s = ApplySettings(yaml, "robot.yaml", RobotSettings(r));
  EXPECT_TRUE(s.ok() || s.code() == StatusCode::kInvalidArgument) << s.ToString();
  return s.message();
}

// A file sets exactly the keys it names, of every type; an empty file sets nothing.
TEST(SettingsTableTest, SetsOnlyTheNamedKeys) {
  Robot r;
  EXPECT_EQ(Apply("body:\n  wheels: 6\n  memory: 4000000000000\n  lights: true\n"
                  "drive:\n  drive: ackermann\n  camera_cols: 0\n",
                  &r),
            "");
  EXPECT_EQ(r.wheels, 6);
  EXPECT_EQ(r.memory, int64_t{4000000000000});
  EXPECT_TRUE(r.lights);
  EXPECT_EQ(r.drive, "ackermann");
  EXPECT_EQ(r.camera_cols, 0);  // the "off" value, outside the range
  EXPECT_EQ(r.speed, Robot().speed);
  EXPECT_EQ(r.label, Robot().label);
  Robot untouched;
  EXPECT_EQ(Apply("", &untouched), "");
  EXPECT_EQ(Apply("# only a comment\n", &untouched), "");
  EXPECT_EQ(untouched.wheels, 4);
}

// Each way a file can be wrong is an error naming the file and the section or key.
TEST(SettingsTableTest, EachMistakeIsNamed) {
  Robot r;
  EXPECT_EQ(Apply("body: [wheels", &r).rfind("robot.yaml: not valid YAML: ", 0), 0u);
  EXPECT_EQ(Apply("- body\n", &r), "robot.yaml: expected sections of key: value settings");
  EXPECT_EQ(Apply("legs:\n  count: 2\n", &r), "robot.yaml: unknown section 'legs'");
  EXPECT_EQ(Apply("body: 5\n", &r), "robot.yaml: section 'body' must hold key: value pairs");
  EXPECT_EQ(Apply("body:\n  wheel: 5\n", &r), "robot.yaml: unknown key 'body.wheel'");
  EXPECT_EQ(Apply("drive:\n  wheels: 5\n", &r), "robot.yaml: unknown key 'drive.wheels'");
  EXPECT_EQ(Apply("body:\n  wheels: 2.5\n", &r), "robot.yaml: body.wheels must be an integer");
  EXPECT_EQ(Apply("body:\n  speed: fast\n", &r), "robot.yaml: body.speed must be a number");
  EXPECT_EQ(Apply("body:\n  lights: maybe\n", &r), "robot.yaml: body.lights must be true or false");
  EXPECT_EQ(Apply("drive:\n  label: [a, b]\n", &r), "robot.yaml: drive.label must be a string");
  EXPECT_EQ(Apply("body:\n  wheels: 9\n", &r), "robot.yaml: body.wheels = 9 is outside [2, 8]");
  EXPECT_EQ(Apply("body:\n  speed: -0.5\n", &r),
            "robot.yaml: body.speed = -0.5 is outside [0, 3] m/s");
  EXPECT_EQ(Apply("drive:\n  camera_cols: 2\n", &r),
            "robot.yaml: drive.camera_cols = 2 is outside 0 or [4, 64]");
  EXPECT_EQ(Apply("drive:\n  drive: tank\n", &r),
            "robot.yaml: drive.drive = 'tank' is not one of diff | ackermann");
  EXPECT_EQ(Apply("body:\n  speed: .nan\n", &r),
            "robot.yaml: body.speed = .nan is outside [0, 3] m/s");
  // A value out of range is never stored.
  EXPECT_EQ(r.wheels, 4);
  EXPECT_EQ(r.drive, "diff");
}

// Keys are applied in file order: before the first bad one, the targets are already set
// (which is why callers apply to a copy).
TEST(SettingsTableTest, AppliesInFileOrderUpToTheFirstError) {
  Robot r;
  EXPECT_NE(Apply("body:\n  wheels: 6\n  speed: 9\n  lights: true\n", &r), "");
  EXPECT_EQ(r.wheels, 6);
  EXPECT_EQ(r.speed, Robot().speed);
  EXPECT_FALSE(r.lights);
}

// A command-line value is read as a file's would be, named by `where` in errors.
TEST(SettingsTableTest, AppliesOneCommandLineValue) {
  Robot r;
  const SettingTable table = RobotSettings(&r);
  EXPECT_TRUE(ApplySetting(table[0], "3", "--wheels").ok());
  EXPECT_EQ(r.wheels, 3);
  EXPECT_TRUE(ApplySetting(table[3], "true", "--lights").ok());
  EXPECT_TRUE(r.lights);
  EXPECT_EQ(ApplySetting(table[0], "three", "--wheels").message(), "--wheels must be an integer");
  EXPECT_EQ(ApplySetting(table[1], "4", "--speed").message(), "--speed = 4 is outside [0, 3] m/s");
  EXPECT_EQ(ApplySetting(table[4], "tank", "--drive").message(),
            "--drive = 'tank' is not one of diff | ackermann");
  EXPECT_EQ(r.wheels, 3);
}

// Values that YAML reads specially (a '#', a ': ', a leading quote, an empty string, a
// string that looks like a boolean) survive both printed forms.
TEST(SettingsTableTest, PrintedValuesReadBack) {
  for (const std::string label : {"a # not a comment", "key: value", "'quoted", "", "yes"}) {
    SCOPED_TRACE("label [" + label + "]");
    Robot r;
    r.label = label;
    r.speed = 0.00625;
    r.memory = 100000000000;  // 12 digits: the most the documented form prints exactly
    r.lights = true;
    for (const std::string& text : {SettingsToYaml(RobotSettings(&r)),
                                    SettingsToDocumentedYaml(RobotSettings(&r), "# robot\n")}) {
      Robot back;
      back.lights = false;
      ASSERT_EQ(Apply(text, &back), "") << text;
      EXPECT_EQ(back.label, label) << text;
      EXPECT_EQ(back.speed, 0.00625);
      EXPECT_EQ(back.memory, int64_t{100000000000});
      EXPECT_TRUE(back.lights);
    }
  }
}

// The documented form: the preamble, each section's notes as comments above it, one line
// per key with its value, and the help and accepted values aligned at column 30 (one space
// after a longer line); booleans say no range, a free string without help no comment.
TEST(SettingsTableTest, DocumentedFormLayout) {
  Robot r;
  r.memory = 1000000;
  const std::string text = SettingsToDocumentedYaml(RobotSettings(&r), "# Robot settings.\n",
                                                    {{"drive", "How it moves.\nTwo lines."}});
  const std::string expected =
      "# Robot settings.\n"
      "body:\n"
      "  wheels: 4                   # wheels on the ground; [2, 8]\n"
      "  speed: 1.5                  # [0, 3] m/s\n"
      "  memory: 1000000             # [1024, 10000000000000] bytes\n"
      "  lights: false               # headlights on\n"
      "# How it moves.\n"
      "# Two lines.\n"
      "drive:\n"
      "  drive: diff                 # diff | ackermann\n"
      "  label: r2\n"
      "  camera_cols: 0              # 0 or [4, 64]\n";
  EXPECT_EQ(text, expected);
}

// The plain YAML form lists the sections and keys in the table's order.
TEST(SettingsTableTest, YamlFollowsTheTableOrder) {
  Robot r;
  const std::string text = SettingsToYaml(RobotSettings(&r));
  size_t at = 0;
  for (const char* key : {"body:", "wheels:", "speed:", "memory:", "lights:", "drive:", "drive:",
                          "label:", "camera_cols:"}) {
    const size_t next = text.find(key, at);
    ASSERT_NE(next, std::string::npos) << key << " after " << at << " in\n" << text;
    at = next + 1;
  }
}

// A settings file is read whole; a missing one is NotFound naming it.
TEST(SettingsTableTest, ReadsSettingsFiles) {
  const test::ScratchDir dir("settings");
  const std::string path = dir.File("robot.yaml");
  test::WriteFileBytes(path, "body:\n  wheels: 6\n# no newline at the end");
  const StatusOr<std::string> text = ReadSettingsFile(path);
  ASSERT_TRUE(text.ok());
  EXPECT_EQ(*text, "body:\n  wheels: 6\n# no newline at the end");
  const StatusOr<std::string> missing = ReadSettingsFile(dir.File("absent.yaml"));
  EXPECT_EQ(missing.status().code(), StatusCode::kNotFound);
  EXPECT_NE(missing.status().message().find(dir.File("absent.yaml")), std::string::npos);
}

}  // namespace
}  // namespace sceneloc
