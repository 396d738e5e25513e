#include "common/util/settings.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>

namespace sceneloc {
namespace {

struct Example {
  int count = 5;
  double ratio = 0.5;
  int64_t bytes = 1024;
  std::string mode = "fast";
  std::string free_text;
  bool enabled = true;
  int cols = 0;
};

SettingTable ExampleSettings(Example* e) {
  return {
      Setting("a", "count", &e->count).Range(1, 10).Help("how many"),
      Setting("a", "ratio", &e->ratio).Range(0, 1),
      Setting("a", "bytes", &e->bytes).Range(1024, 1e15).Unit("bytes"),
      Setting("b", "mode", &e->mode).Choices({"fast", "slow"}),
      Setting("b", "free_text", &e->free_text),
      Setting("b", "enabled", &e->enabled),
      Setting("b", "cols", &e->cols).Range(4, 64).Off(0).Flag("grid-cols"),
  };
}

// Values inside their ranges and choices pass; each kind of violation names the field,
// its value and what it accepts.
TEST(SettingsTest, ChecksRangesAndChoices) {
  Example e;
  EXPECT_TRUE(CheckSettings(ExampleSettings(&e)).ok());
  e.count = 11;
  Status s = CheckSettings(ExampleSettings(&e));
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(), "a.count = 11 is outside [1, 10]");
  e.count = 5;
  e.bytes = 10;
  EXPECT_EQ(CheckSettings(ExampleSettings(&e)).message(),
            "a.bytes = 10 is outside [1024, 1e+15] bytes");
  e.bytes = 1024;
  e.mode = "medium";
  EXPECT_EQ(CheckSettings(ExampleSettings(&e)).message(),
            "b.mode = 'medium' is not one of fast | slow");
}

// NaN and infinities are never in range; the "off" value is accepted outside the range.
TEST(SettingsTest, NonFiniteNeverPassesAndOffIsAccepted) {
  Example e;
  e.ratio = std::nan("");
  EXPECT_FALSE(CheckSettings(ExampleSettings(&e)).ok());
  e.ratio = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(CheckSettings(ExampleSettings(&e)).ok());
  e.ratio = 0.5;
  e.cols = 0;
  EXPECT_TRUE(CheckSettings(ExampleSettings(&e)).ok());
  e.cols = 2;
  EXPECT_EQ(CheckSettings(ExampleSettings(&e)).message(), "b.cols = 2 is outside 0 or [4, 64]");
}

// Flags default to the key with dashes; an explicit flag wins; Describe reads as a user
// would write the values.
TEST(SettingsTest, FlagNamesAndDescriptions) {
  Example e;
  const SettingTable t = ExampleSettings(&e);
  EXPECT_EQ(t[0].FlagName(), "count");
  EXPECT_EQ(t[4].FlagName(), "free-text");
  EXPECT_EQ(t[6].FlagName(), "grid-cols");
  EXPECT_EQ(t[0].Name(), "a.count");
  EXPECT_EQ(t[1].Describe(), "[0, 1]");
  EXPECT_EQ(t[3].Describe(), "fast | slow");
  EXPECT_EQ(t[4].Describe(), "");
  EXPECT_EQ(t[5].Describe(), "true | false");
  EXPECT_TRUE(t[0].is_number());
  EXPECT_FALSE(t[3].is_number());
  EXPECT_EQ(t[0].help, "how many");
}

// Numbers print in a short form that reads back exactly: whole numbers as integers (an
// integer setting of 13 digits must not become "1.23456789012e+12"), others shortest.
TEST(SettingsTest, FormatsNumbersSoTheyReadBack) {
  EXPECT_EQ(FormatSettingNumber(0.00625), "0.00625");
  EXPECT_EQ(FormatSettingNumber(1.0), "1");
  EXPECT_EQ(FormatSettingNumber(8388608), "8388608");
  EXPECT_EQ(FormatSettingNumber(1e6), "1000000");
  EXPECT_EQ(FormatSettingNumber(1234567890123.0), "1234567890123");
  EXPECT_EQ(FormatSettingNumber(-2e12), "-2000000000000");
  EXPECT_EQ(FormatSettingNumber(1e15), "1e+15");
  for (const double v : {0.1 + 0.2, 1.0 / 3, 6.02214076e23, -0.00123456789012345}) {
    EXPECT_EQ(std::stod(FormatSettingNumber(v)), v) << FormatSettingNumber(v);
  }
}

// A subnormal value (a map file can hold any double) prints and reads back; it used to
// throw out_of_range from std::stod, which the map fuzzer found.
TEST(SettingsTest, FormatsSubnormalNumbers) {
  for (const double v : {4.9406564584124654e-324, -1.5e-310, 2.2250738585072e-309}) {
    const std::string text = FormatSettingNumber(v);
    EXPECT_EQ(std::strtod(text.c_str(), nullptr), v) << text;
  }
  // A subnormal outside its range is refused with a message, not an exception.
  Example e;
  e.ratio = -1.5e-310;
  const Status s = CheckSettings(ExampleSettings(&e));
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("a.ratio = -1.5"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace sceneloc
