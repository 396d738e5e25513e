// Settings files (YAML) for the tools and the server. Every field has a default in its
// options struct; a file overrides only what it names. An unknown section or key, a value
// of the wrong type or out of range is an error naming the file and the key, so a typo
// never silently leaves a default in force.
//
// configs/train.yaml:   extractor:, tracking:, landmarks:, selection:
// configs/match.yaml:   matching:
#pragma once

#include <string>

#include "common/config/settings_table.h"
#include "common/map/train_options.h"
#include "common/matching/localiser.h"
#include "common/util/status.h"

namespace sceneloc {

// Reads a training settings file over `options` (which holds the defaults on entry).
Status LoadTrainOptions(const std::string& path, TrainOptions* options);
// Reads a matching settings file over `options`.
Status LoadMatchOptions(const std::string& path, MatchOptions* options);

// Both from YAML text (for tests); `name` names the source in errors.
Status ParseTrainOptions(const std::string& yaml, const std::string& name, TrainOptions* options);
Status ParseMatchOptions(const std::string& yaml, const std::string& name, MatchOptions* options);

// The fields of each file are declared once, beside their structs: TrainSettings
// (common/map/train_options.h) and MatchSettings (common/matching/localiser.h).

// The settings as YAML text, in the same layout the files use (printed by the tools and
// stored nowhere else: the map file stores the structs themselves).
std::string TrainOptionsToYaml(const TrainOptions& options);
std::string MatchOptionsToYaml(const MatchOptions& options);

// The settings as documented files (--print-config of sceneloc-train and sceneloc-eval).
// For the defaults they are configs/train.yaml and configs/match.yaml, exactly
// (tests/config checks it).
std::string DocumentedTrainSettings(const TrainOptions& options = TrainOptions());
std::string DocumentedMatchSettings(const MatchOptions& options = MatchOptions());

}  // namespace sceneloc
