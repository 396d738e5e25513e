// The YAML side of the settings tables (common/util/settings.h), shared by every settings
// file of the project (training, matching, server) so that all of them behave alike: a file
// names sections of key: value pairs, overrides only what it names, and an unknown section
// or key, a value of the wrong type, out of range or not among its choices is an error
// naming the source and the key, so a typo never silently leaves a default in force.
#pragma once

#include <map>
#include <string>

#include "common/util/settings.h"
#include "common/util/status.h"

namespace sceneloc {

// Applies YAML text to the table's targets, in file order. On error, some targets may
// already be set: callers apply to a copy and keep it only on success.
Status ApplySettings(const std::string& yaml, const std::string& name, const SettingTable& table);

// Sets one field from the text of a command-line value; `where` names it in errors.
Status ApplySetting(const SettingField& field, const std::string& value, const std::string& where);

// The targets' current values as YAML, in the table's order and sections.
std::string SettingsToYaml(const SettingTable& table);

// The same as a documented settings file: `preamble` (comment lines), then each section and
// key with its current value and a comment with its help and accepted values, aligned. The
// files in configs/ are this output for the defaults (tests/config checks it;
// `sceneloc-train --print-config`, `sceneloc-eval --print-config` and
// `sceneloc-server --print-config` print it).
// `section_notes` adds comment lines above a section (by name; '\n' between lines).
std::string SettingsToDocumentedYaml(const SettingTable& table, const std::string& preamble,
                                     const std::map<std::string, std::string>& section_notes = {});

// The whole text of a settings file; NotFound naming it when it cannot be read.
StatusOr<std::string> ReadSettingsFile(const std::string& path);

}  // namespace sceneloc
