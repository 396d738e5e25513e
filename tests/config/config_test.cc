#include "common/config/config.h"

#include <gtest/gtest.h>

namespace sceneloc {
namespace {

// A file overrides exactly the keys it names and keeps the other defaults.
TEST(ConfigTest, OverridesOnlyNamedKeys) {
  TrainOptions o;
  ASSERT_TRUE(
      ParseTrainOptions("extractor:\n  max_features: 500\nselection:\n  eta: 40\n", "t", &o).ok());
  EXPECT_EQ(o.extractor.max_features, 500);
  EXPECT_EQ(o.eta, 40);
  EXPECT_EQ(o.track_distance_threshold, TrainOptions().track_distance_threshold);
}

// Unknown sections and keys, wrong types and out-of-range values are errors naming them,
// and leave the options untouched.
TEST(ConfigTest, RejectsUnknownKeysWrongTypesAndRanges) {
  TrainOptions o;
  const TrainOptions before = o;
  Status s = ParseTrainOptions("extractor:\n  max_feature: 5\n", "train.yaml", &o);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("unknown key 'extractor.max_feature'"), std::string::npos);
  EXPECT_NE(s.message().find("train.yaml"), std::string::npos);
  // A key of an older version says it is gone and why.
  s = ParseTrainOptions("place_index:\n  holistic_dims: 32\n", "old.yaml", &o);
  EXPECT_NE(s.message().find("old.yaml: place_index.holistic_dims is no longer a setting"),
            std::string::npos)
      << s.message();
  s = ParseTrainOptions("trackin:\n  x: 1\n", "t", &o);
  EXPECT_NE(s.message().find("unknown section 'trackin'"), std::string::npos);
  s = ParseTrainOptions("tracking:\n  distance_threshold: abc\n", "t", &o);
  EXPECT_NE(s.message().find("tracking.distance_threshold must be a number"), std::string::npos);
  s = ParseTrainOptions("selection:\n  eta: 2.5\n", "t", &o);
  EXPECT_NE(s.message().find("selection.eta must be an integer"), std::string::npos);
  s = ParseTrainOptions("extractor:\n  working_size: 3\n", "t", &o);
  EXPECT_NE(s.message().find("extractor.working_size = 3 is outside [64, 4096] pixels"),
            std::string::npos);
  s = ParseTrainOptions("[1, 2]", "t", &o);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(o.extractor.max_features, before.extractor.max_features);
  EXPECT_EQ(o.extractor.working_size, before.extractor.working_size);
}

// Matching settings parse, including booleans.
TEST(ConfigTest, MatchOptions) {
  MatchOptions o;
  ASSERT_TRUE(
      ParseMatchOptions("matching:\n  include_centre_term: false\n  s_min: 0.25\n", "m", &o).ok());
  EXPECT_FALSE(o.include_centre_term);
  EXPECT_DOUBLE_EQ(o.s_min, 0.25);
  EXPECT_EQ(ParseMatchOptions("matching:\n  use_neighbourhood: maybe\n", "m", &o).code(),
            StatusCode::kInvalidArgument);
  // The decision threshold is a probability; the confidence model one of two names.
  Status s = ParseMatchOptions("matching:\n  min_confidence: 1.5\n", "m", &o);
  EXPECT_NE(s.message().find("matching.min_confidence = 1.5 is outside [0, 1]"), std::string::npos)
      << s.message();
  s = ParseMatchOptions("matching:\n  confidence_model: bayes\n", "m", &o);
  EXPECT_NE(
      s.message().find("matching.confidence_model = 'bayes' is not one of calibrated | paper"),
      std::string::npos)
      << s.message();
  ASSERT_TRUE(
      ParseMatchOptions("matching:\n  confidence_model: paper\n  min_confidence: 0\n", "m", &o)
          .ok());
  EXPECT_EQ(o.confidence_model, "paper");
  EXPECT_EQ(o.min_confidence, 0.0);
}

// The YAML the tools print parses back to the same settings.
TEST(ConfigTest, RoundTripsThroughYaml) {
  TrainOptions o;
  o.eta = 33;
  o.extractor.working_size = 640;
  o.ransac_threshold = 0.005;
  TrainOptions back;
  ASSERT_TRUE(ParseTrainOptions(TrainOptionsToYaml(o), "rt", &back).ok());
  EXPECT_EQ(back.eta, 33);
  EXPECT_EQ(back.extractor.working_size, 640);
  EXPECT_DOUBLE_EQ(back.ransac_threshold, 0.005);
}

// The shipped settings files load and hold the defaults the code documents.
TEST(ConfigTest, ShippedFilesLoad) {
  TrainOptions t;
  ASSERT_TRUE(LoadTrainOptions(std::string(SCENELOC_CONFIGS_DIR) + "/train.yaml", &t).ok());
  MatchOptions m;
  ASSERT_TRUE(LoadMatchOptions(std::string(SCENELOC_CONFIGS_DIR) + "/match.yaml", &m).ok());
  EXPECT_EQ(LoadTrainOptions("/nonexistent/train.yaml", &t).code(), StatusCode::kNotFound);
}

// The documented files in configs/ are exactly what the declarations print for the defaults:
// every key, its default, its help and range. A setting added, renamed or re-defaulted
// without regenerating them (sceneloc-train --print-config > configs/train.yaml,
// sceneloc-eval --print-config > configs/match.yaml) fails here.
TEST(ConfigTest, DocumentedConfigsMatchTheDeclarations) {
  const auto read = [](const std::string& name) {
    const StatusOr<std::string> text =
        ReadSettingsFile(std::string(SCENELOC_CONFIGS_DIR) + "/" + name);
    EXPECT_TRUE(text.ok()) << name;
    return text.ok() ? *text : std::string();
  };
  EXPECT_EQ(read("train.yaml"), DocumentedTrainSettings());
  EXPECT_EQ(read("match.yaml"), DocumentedMatchSettings());
}

// The documented text reads back to the options it was printed from.
TEST(ConfigTest, DocumentedSettingsRoundTrip) {
  TrainOptions t;
  t.extractor.sigma = 2.5;
  t.eta = 40;
  TrainOptions t2;
  ASSERT_TRUE(ParseTrainOptions(DocumentedTrainSettings(t), "doc", &t2).ok());
  EXPECT_EQ(TrainOptionsToYaml(t2), TrainOptionsToYaml(t));
  MatchOptions m;
  m.confidence_model = "paper";
  m.sequence.max_forward = 3;
  MatchOptions m2;
  ASSERT_TRUE(ParseMatchOptions(DocumentedMatchSettings(m), "doc", &m2).ok());
  EXPECT_EQ(MatchOptionsToYaml(m2), MatchOptionsToYaml(m));
}

// The variant files beside them (the paper's settings) are valid.
TEST(ConfigTest, PaperConfigsAreValid) {
  TrainOptions t;
  EXPECT_TRUE(LoadTrainOptions(std::string(SCENELOC_CONFIGS_DIR) + "/paper-train.yaml", &t).ok());
  MatchOptions m;
  EXPECT_TRUE(LoadMatchOptions(std::string(SCENELOC_CONFIGS_DIR) + "/paper-match.yaml", &m).ok());
}

}  // namespace
}  // namespace sceneloc
