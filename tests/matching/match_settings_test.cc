// The matching settings, declared once (common/matching/match_settings.cc): the table of
// matching: and sequence: bound to the options it sets, and Validate() holding the options
// to the ranges and choices the headers document, naming the setting that is wrong.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <variant>

#include "common/matching/localiser.h"
#include "common/matching/sequence_options.h"

namespace sceneloc {
namespace {

// Expects `status` to be InvalidArgument naming `setting` ("section.key") first.
void ExpectNames(const Status& status, const std::string& setting) {
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument) << setting;
  EXPECT_EQ(status.message().rfind(setting + " = ", 0), 0u) << status.message();
}

// The defaults are valid.
TEST(MatchSettingsTest, DefaultsAreValid) {
  EXPECT_TRUE(MatchOptions().Validate().ok()) << MatchOptions().Validate().ToString();
  EXPECT_TRUE(SequenceOptions().Validate().ok());
}

// The table holds both sections, each setting once and bound to a field of its own of the
// options it was made for (the sequence: part inside MatchOptions::sequence); every number
// has a range, and every command-line flag is unique (the server takes them all on one
// command line).
TEST(MatchSettingsTest, TableBindsEverySettingToItsOwnField) {
  MatchOptions o;
  const char* const begin = reinterpret_cast<const char*>(&o);
  std::set<std::string> names, flags, sections;
  std::set<const void*> fields;
  for (const SettingField& f : MatchSettings(&o)) {
    SCOPED_TRACE(f.Name());
    EXPECT_TRUE(names.insert(f.Name()).second);
    EXPECT_TRUE(flags.insert(f.FlagName()).second) << f.FlagName();
    sections.insert(f.section);
    if (f.is_number()) {
      EXPECT_LT(f.min, f.max);
    }
    const char* field =
        std::visit([](auto* p) { return reinterpret_cast<const char*>(p); }, f.target);
    EXPECT_TRUE(fields.insert(field).second);
    EXPECT_TRUE(field >= begin && field < begin + sizeof(o));
    if (f.section == "sequence") {
      const char* sequence = reinterpret_cast<const char*>(&o.sequence);
      EXPECT_TRUE(field >= sequence && field < sequence + sizeof(o.sequence));
    }
  }
  EXPECT_EQ(sections, (std::set<std::string>{"matching", "sequence"}));
  EXPECT_EQ(flags.count("min-confidence") + flags.count("sequence-min-confidence"), 2u);
}

// Numbers outside their documented ranges are refused, naming the setting; the range ends
// themselves are accepted.
TEST(MatchSettingsTest, RangesAreTheDocumentedOnes) {
  struct Case {
    const char* setting;
    void (*set)(MatchOptions*, double);
    double lowest, highest;  // accepted
    double below, above;     // refused
  };
  const Case cases[] = {
      {"matching.s_min", [](MatchOptions* o, double v) { o->s_min = v; }, 1e-6, 1, 0, 1.01},
      {"matching.min_confidence", [](MatchOptions* o, double v) { o->min_confidence = v; }, 0, 1,
       -0.01, 1.01},
      {"matching.top_k", [](MatchOptions* o, double v) { o->top_k = static_cast<int>(v); }, 1, 1000,
       0, 1001},
      {"matching.verify_ransac_iterations",
       [](MatchOptions* o, double v) { o->verify_ransac_iterations = static_cast<int>(v); }, 1,
       100000, 0, 100001},
      {"matching.verify_angle_tolerance",
       [](MatchOptions* o, double v) { o->verify_angle_tolerance = v; }, 0, 180, -1, 181},
      {"sequence.max_forward",
       [](MatchOptions* o, double v) { o->sequence.max_forward = static_cast<int>(v); }, -1, 32, -2,
       33},
      {"sequence.speed_change", [](MatchOptions* o, double v) { o->sequence.speed_change = v; }, 0,
       1, -0.01, 1.01},
      {"sequence.speed_jump", [](MatchOptions* o, double v) { o->sequence.speed_jump = v; }, 0, 1,
       -0.01, 1.01},
      {"sequence.evidence_spread",
       [](MatchOptions* o, double v) { o->sequence.evidence_spread = v; }, 0, 1, -0.01, 1.01},
      {"sequence.evidence_floor", [](MatchOptions* o, double v) { o->sequence.evidence_floor = v; },
       0, 0.99, -0.01, 1},
      {"sequence.support_weight", [](MatchOptions* o, double v) { o->sequence.support_weight = v; },
       0, 10, -0.01, 10.5},
      {"sequence.support_switch", [](MatchOptions* o, double v) { o->sequence.support_switch = v; },
       0, 0.5, -0.01, 0.51},
      {"sequence.evidence_weight",
       [](MatchOptions* o, double v) { o->sequence.evidence_weight = v; }, 1e-6, 1, 0, 1.5},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.setting);
    for (const double ok : {c.lowest, c.highest}) {
      MatchOptions o;
      c.set(&o, ok);
      EXPECT_TRUE(o.Validate().ok()) << ok << ": " << o.Validate().ToString();
    }
    for (const double bad : {c.below, c.above}) {
      MatchOptions o;
      c.set(&o, bad);
      ExpectNames(o.Validate(), c.setting);
    }
  }
}

// -1 ("from the map") is the one value below the motion band's range; NaN is never a
// valid number.
TEST(MatchSettingsTest, OffValuesAndNaN) {
  SequenceOptions s;
  s.max_backward = -1;
  EXPECT_TRUE(s.Validate().ok());
  s.max_backward = -2;
  ExpectNames(s.Validate(), "sequence.max_backward");
  MatchOptions o;
  o.verify_weight = std::numeric_limits<double>::quiet_NaN();
  ExpectNames(o.Validate(), "matching.verify_weight");
  o = MatchOptions();
  o.sequence.jump = std::numeric_limits<double>::infinity();
  ExpectNames(o.Validate(), "sequence.jump");
}

// The confidence model is one of its two names, and the error lists them.
TEST(MatchSettingsTest, ConfidenceModelIsOneOfTwo) {
  MatchOptions o;
  o.confidence_model = "paper";
  EXPECT_TRUE(o.Validate().ok());
  o.confidence_model = "Calibrated";
  const Status s = o.Validate();
  EXPECT_EQ(s.message(),
            "matching.confidence_model = 'Calibrated' is not one of calibrated | paper");
}

// Validate checks a copy: the options keep their values, and the first bad setting in the
// table's order is the one named.
TEST(MatchSettingsTest, ValidateNamesTheFirstBadSetting) {
  MatchOptions o;
  o.top_k = 0;
  o.s_min = 2;
  o.sequence.leave = 2;
  ExpectNames(o.Validate(), "matching.s_min");
  EXPECT_EQ(o.s_min, 2);
  o.s_min = 0.3;
  ExpectNames(o.Validate(), "matching.top_k");
  o.top_k = 5;
  ExpectNames(o.Validate(), "sequence.leave");
  ExpectNames(o.sequence.Validate(), "sequence.leave");
}

}  // namespace
}  // namespace sceneloc
