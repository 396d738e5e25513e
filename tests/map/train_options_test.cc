#include "common/map/train_options.h"

#include <gtest/gtest.h>

#include <string>

#include "common/map/map_io.h"
#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

// The defaults are valid, and every declared field's range holds its default.
TEST(TrainOptionsTest, DefaultsAreInRange) {
  TrainOptions o;
  EXPECT_TRUE(o.Validate().ok());
  for (const SettingField& f : TrainSettings(&o)) {
    EXPECT_TRUE(CheckSetting(f).ok()) << f.Name();
  }
}

// Validate() holds a struct built in code to the same ranges a settings file is held to.
TEST(TrainOptionsTest, ValidateUsesTheDeclaredRanges) {
  TrainOptions o;
  o.extractor.sigma = 500;
  EXPECT_EQ(o.Validate().message(), "extractor.sigma = 500 is outside [0.1, 10] pixels");
  o = TrainOptions();
  o.extractor.holistic.cols = 2;
  EXPECT_EQ(o.Validate().message(), "extractor.holistic_cols = 2 is outside 0 or [4, 64]");
  o = TrainOptions();
  o.extractor.holistic.max_shift = o.extractor.holistic.cols;
  EXPECT_FALSE(o.Validate().ok());
  o = TrainOptions();
  o.ransac_confidence = 1.0;
  EXPECT_NE(o.Validate().message().find("tracking.ransac_confidence = 1 is outside"),
            std::string::npos);
}

// A map file whose stored settings are out of range is refused on load, with the field
// named, as the same settings in a YAML file would be.
TEST(TrainOptionsTest, MapFileWithOutOfRangeSettingsIsRefused) {
  Map map = test::MakeRandomMap(4, 20, 7);
  map.options.extractor.sigma = 500;
  const StatusOr<Map> loaded = ParseMap(SerializeMap(map), "bad.scnl");
  ASSERT_FALSE(loaded.ok());
  EXPECT_NE(loaded.status().message().find("extractor.sigma = 500 is outside"), std::string::npos)
      << loaded.status().message();
}

}  // namespace
}  // namespace sceneloc
