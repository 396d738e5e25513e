#include "common/config/settings_table.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <type_traits>

namespace sceneloc {
namespace {

const char* TypeName(const SettingField& f) {
  if (std::holds_alternative<std::string*>(f.target)) return "a string";
  if (std::holds_alternative<bool*>(f.target)) return "true or false";
  if (std::holds_alternative<double*>(f.target)) return "a number";
  return "an integer";
}

// Range check before the value is stored: an out-of-range integer never reaches its field.
Status CheckNumber(const SettingField& f, double v, const std::string& text,
                   const std::string& where) {
  if (InRange(f, v)) return Status::Ok();
  return InvalidArgument(where + " = " + text + " is outside " + f.Describe());
}

Status SetFromNode(const SettingField& f, const YAML::Node& value, const std::string& where) {
  try {
    if (!value.IsScalar()) return InvalidArgument(where + " must be " + TypeName(f));
    if (auto* s = std::get_if<std::string*>(&f.target)) {
      const std::string text = value.as<std::string>();
      if (!f.choices.empty() &&
          std::find(f.choices.begin(), f.choices.end(), text) == f.choices.end()) {
        return InvalidArgument(where + " = '" + text + "' is not one of " + f.Describe());
      }
      **s = text;
    } else if (auto* b = std::get_if<bool*>(&f.target)) {
      **b = value.as<bool>();
    } else {
      SCENELOC_RETURN_IF_ERROR(CheckNumber(f, value.as<double>(), value.as<std::string>(), where));
      if (auto* i = std::get_if<int*>(&f.target)) {
        **i = value.as<int>();
      } else if (auto* l = std::get_if<int64_t*>(&f.target)) {
        **l = value.as<int64_t>();
      } else {
        *std::get<double*>(f.target) = value.as<double>();
      }
    }
  } catch (const YAML::Exception&) {
    return InvalidArgument(where + " must be " + TypeName(f));
  }
  return Status::Ok();
}

// Keys that settings files once held, with why they are gone: a file that still sets one is
// told so rather than that the key is unknown.
struct RetiredKey {
  const char* section;
  const char* key;
  const char* why;
};
constexpr RetiredKey kRetiredKeys[] = {
    {"place_index", "holistic_dims",
     "map format 8 codes the holistic descriptors' cells instead of projecting them on axes"},
};

}  // namespace

Status ApplySettings(const std::string& yaml, const std::string& name, const SettingTable& table) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    return InvalidArgument(name + ": not valid YAML: " + e.what());
  }
  if (root.IsNull()) return Status::Ok();
  if (!root.IsMap()) return InvalidArgument(name + ": expected sections of key: value settings");
  for (const auto& section : root) {
    const std::string section_name = section.first.as<std::string>();
    const bool known = std::any_of(table.begin(), table.end(), [&](const SettingField& f) {
      return f.section == section_name;
    });
    if (!known) return InvalidArgument(name + ": unknown section '" + section_name + "'");
    if (!section.second.IsMap()) {
      return InvalidArgument(name + ": section '" + section_name + "' must hold key: value pairs");
    }
    for (const auto& entry : section.second) {
      const std::string key = entry.first.as<std::string>();
      const auto field = std::find_if(table.begin(), table.end(), [&](const SettingField& f) {
        return f.section == section_name && f.key == key;
      });
      const std::string where = name + ": " + section_name + "." + key;
      if (field == table.end()) {
        for (const RetiredKey& retired : kRetiredKeys) {
          if (section_name == retired.section && key == retired.key) {
            return InvalidArgument(where + " is no longer a setting (" + retired.why +
                                   "): remove it");
          }
        }
        return InvalidArgument(name + ": unknown key '" + section_name + "." + key + "'");
      }
      SCENELOC_RETURN_IF_ERROR(SetFromNode(*field, entry.second, where));
    }
  }
  return Status::Ok();
}

Status ApplySetting(const SettingField& field, const std::string& value, const std::string& where) {
  return SetFromNode(field, YAML::Node(value), where);
}

std::string SettingsToYaml(const SettingTable& table) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  std::string open;
  for (const SettingField& f : table) {
    if (f.section != open) {
      if (!open.empty()) out << YAML::EndMap;
      out << YAML::Key << f.section << YAML::Value << YAML::BeginMap;
      open = f.section;
    }
    out << YAML::Key << f.key << YAML::Value;
    std::visit([&](auto* p) { out << *p; }, f.target);
  }
  if (!open.empty()) out << YAML::EndMap;
  out << YAML::EndMap;
  return out.c_str();
}

namespace {

// One value as it is written in a settings file.
std::string ValueText(const SettingField& f) {
  if (f.is_number()) {
    return std::visit(
        [](auto* p) -> std::string {
          using T = std::decay_t<decltype(*p)>;
          if constexpr (std::is_same_v<T, std::string> || std::is_same_v<T, bool>) {
            return "";
          } else {
            return FormatSettingNumber(static_cast<double>(*p));
          }
        },
        f.target);
  }
  YAML::Emitter out;
  if (const auto* b = std::get_if<bool*>(&f.target)) {
    out << **b;
  } else {
    out << *std::get<std::string*>(f.target);
  }
  return out.c_str();
}

// The comment of one key: its help, then what it accepts (numbers and choices).
std::string Comment(const SettingField& f) {
  std::string accepts = std::holds_alternative<bool*>(f.target) ? "" : f.Describe();
  if (f.help.empty()) return accepts;
  return accepts.empty() ? f.help : f.help + "; " + accepts;
}

}  // namespace

std::string SettingsToDocumentedYaml(const SettingTable& table, const std::string& preamble,
                                     const std::map<std::string, std::string>& section_notes) {
  constexpr size_t kCommentColumn = 30;
  std::string text = preamble;
  std::string open;
  for (const SettingField& f : table) {
    if (f.section != open) {
      open = f.section;
      if (const auto note = section_notes.find(open); note != section_notes.end()) {
        std::istringstream lines(note->second);
        for (std::string line; std::getline(lines, line);) text += "# " + line + "\n";
      }
      text += open + ":\n";
    }
    std::string line = "  " + f.key + ": " + ValueText(f);
    const std::string comment = Comment(f);
    if (!comment.empty()) {
      line.append(line.size() < kCommentColumn ? kCommentColumn - line.size() : 1, ' ');
      line += "# " + comment;
    }
    text += line + "\n";
  }
  return text;
}

StatusOr<std::string> ReadSettingsFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return NotFound("settings file '" + path + "' cannot be opened");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace sceneloc
