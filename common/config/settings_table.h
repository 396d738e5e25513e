// A table-driven reader for YAML settings files, shared by every settings file of the
// project (training, matching, server) so that all of them behave alike: a file names
// sections of key: value pairs, overrides only what it names, and an unknown section or key,
// a value of the wrong type or out of range is an error naming the source and the key, so a
// typo never silently leaves a default in force.
#pragma once

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "common/util/status.h"

namespace sceneloc {

// One settable field: where it is written in a file, where it is stored, its allowed range
// (numbers only) and a help line (for command-line flags).
struct SettingField {
  std::string section;
  std::string key;
  std::variant<std::string*, bool*, int*, int64_t*, double*> target;
  double min = 0;
  double max = 0;
  std::string help;
  std::string flag;  // command-line flag without dashes; empty = the key with '_' -> '-'

  std::string FlagName() const;
};

using SettingTable = std::vector<SettingField>;

// Applies YAML text to the table's targets, in file order. On error, some targets may
// already be set: callers apply to a copy and keep it only on success.
Status ApplySettings(const std::string& yaml, const std::string& name, const SettingTable& table);

// Sets one field from the text of a command-line value; `where` names it in errors.
Status ApplySetting(const SettingField& field, const std::string& value, const std::string& where);

// The targets' current values as YAML, in the table's order and sections.
std::string SettingsToYaml(const SettingTable& table);

// The whole text of a settings file; NotFound naming it when it cannot be read.
StatusOr<std::string> ReadSettingsFile(const std::string& path);

}  // namespace sceneloc
