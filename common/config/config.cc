#include "common/config/config.h"

namespace sceneloc {

Status ParseTrainOptions(const std::string& yaml, const std::string& name, TrainOptions* options) {
  TrainOptions updated = *options;
  SCENELOC_RETURN_IF_ERROR(ApplySettings(yaml, name, TrainSettings(&updated)));
  const Status valid = updated.Validate();
  if (!valid.ok()) return InvalidArgument(name + ": " + valid.message());
  *options = updated;
  return Status::Ok();
}

Status ParseMatchOptions(const std::string& yaml, const std::string& name, MatchOptions* options) {
  MatchOptions updated = *options;
  SCENELOC_RETURN_IF_ERROR(ApplySettings(yaml, name, MatchSettings(&updated)));
  const Status valid = updated.Validate();
  if (!valid.ok()) return InvalidArgument(name + ": " + valid.message());
  *options = updated;
  return Status::Ok();
}

Status LoadTrainOptions(const std::string& path, TrainOptions* options) {
  SCENELOC_ASSIGN_OR_RETURN(const std::string text, ReadSettingsFile(path));
  return ParseTrainOptions(text, path, options);
}

Status LoadMatchOptions(const std::string& path, MatchOptions* options) {
  SCENELOC_ASSIGN_OR_RETURN(const std::string text, ReadSettingsFile(path));
  return ParseMatchOptions(text, path, options);
}

std::string TrainOptionsToYaml(const TrainOptions& options) {
  TrainOptions copy = options;
  return SettingsToYaml(TrainSettings(&copy));
}

std::string MatchOptionsToYaml(const MatchOptions& options) {
  MatchOptions copy = options;
  return SettingsToYaml(MatchSettings(&copy));
}

std::string DocumentedTrainSettings(const TrainOptions& options) {
  TrainOptions copy = options;
  return SettingsToDocumentedYaml(
      TrainSettings(&copy),
      "# sceneloc-train settings, as `sceneloc-train --print-config` prints them (the defaults).\n"
      "# Every key is optional: a missing key keeps the default shown. Each comment gives the\n"
      "# key's meaning and the values it accepts; more in common/map/train_options.h and\n"
      "# common/features/extractor.h. The map file records the settings that made it.\n",
      {{"calibration", "The confidence (common/matching/confidence.h); measured."}});
}

std::string DocumentedMatchSettings(const MatchOptions& options) {
  MatchOptions copy = options;
  return SettingsToDocumentedYaml(
      MatchSettings(&copy),
      "# Recognition settings (sceneloc-eval --config; the server's matching: and sequence:),\n"
      "# as `sceneloc-eval --print-config` prints them (the defaults). Meaning of each:\n"
      "# common/matching/localiser.h.\n",
      {{"sequence",
        "The filter of requests that name a session: common/matching/sequence_options.h;\n"
        "defaults measured in docs/results.md \"Sessions\"."}});
}

}  // namespace sceneloc
