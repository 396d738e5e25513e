// One declaration per setting. Every options struct that a user can set (training,
// matching, the session filter, the server) lists its fields once, as a SettingTable bound
// to an instance: section and key (as written in a YAML file), allowed range, unit and a
// help line. From that one list come the YAML reader and writer (common/config), the
// struct's Validate() (CheckSettings: the same ranges, so a map file or a struct built in
// code is held to exactly what a settings file is), the server's command-line flags and
// their --help, and the documented files in configs/ (tests/config checks they match).
//
// Declaring a field:
//
//   Setting("extractor", "sigma", &o->sigma).Range(0.1, 10).Unit("pixels").Help("...")
//
// Numbers must have a Range; strings may list their Choices; booleans need neither.
#pragma once

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "common/util/status.h"

namespace sceneloc {

struct SettingField {
  using Target = std::variant<std::string*, bool*, int*, int64_t*, double*>;

  std::string section;
  std::string key;
  Target target;
  // Numbers: the closed range [min, max]. `off`, when set, is one more accepted value
  // outside it that switches the feature off (e.g. holistic_cols 0).
  double min = 0;
  double max = 0;
  bool has_off = false;
  double off = 0;
  std::vector<std::string> choices;  // strings: the accepted values (empty = any)
  std::string unit;                  // e.g. "pixels", "ms"; empty for counts and ratios
  std::string help;
  std::string flag;  // command-line flag without dashes; empty = the key with '_' -> '-'

  SettingField&& Range(double lo, double hi) &&;
  SettingField&& Off(double value) &&;
  SettingField&& Choices(std::vector<std::string> values) &&;
  SettingField&& Unit(std::string text) &&;
  SettingField&& Help(std::string text) &&;
  SettingField&& Flag(std::string name) &&;

  bool is_number() const;
  std::string FlagName() const;
  // "section.key".
  std::string Name() const;
  // The accepted values as a reader would write them: "[0.1, 10] pixels", "0 or [4, 64]",
  // "calibrated | paper", "true | false"; empty for a free string.
  std::string Describe() const;
};

// Starts a declaration (the builder methods above finish it).
SettingField Setting(std::string section, std::string key, SettingField::Target target);

using SettingTable = std::vector<SettingField>;

// Whether `value` is accepted by a number field (NaN and infinities never are).
bool InRange(const SettingField& field, double value);

// The field's current value against its range or choices; InvalidArgument naming it
// ("extractor.sigma = 500 is outside [0.1, 10]") otherwise.
Status CheckSetting(const SettingField& field);

// CheckSetting over the whole table, in order; the first failure.
Status CheckSettings(const SettingTable& table);

// A number as settings print it, in a form that reads back exactly: whole numbers below
// 1e15 as integers ("1000000", "1234567890123"), others in the shortest such form
// ("0.00625", "1e+15").
std::string FormatSettingNumber(double value);

}  // namespace sceneloc
