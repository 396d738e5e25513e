#include "common/config/settings_table.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <fstream>
#include <sstream>

namespace sceneloc {
namespace {

const char* TypeName(const SettingField& f) {
  if (std::holds_alternative<std::string*>(f.target)) return "a string";
  if (std::holds_alternative<bool*>(f.target)) return "true or false";
  if (std::holds_alternative<double*>(f.target)) return "a number";
  return "an integer";
}

Status CheckRange(const SettingField& f, double v, const std::string& text,
                  const std::string& where) {
  if (v >= f.min && v <= f.max) return Status::Ok();
  std::ostringstream m;
  m << where << " = " << text << " is out of range [" << f.min << ", " << f.max << "]";
  return InvalidArgument(m.str());
}

Status SetFromNode(const SettingField& f, const YAML::Node& value, const std::string& where) {
  try {
    if (!value.IsScalar()) return InvalidArgument(where + " must be " + TypeName(f));
    if (auto* s = std::get_if<std::string*>(&f.target)) {
      **s = value.as<std::string>();
    } else if (auto* b = std::get_if<bool*>(&f.target)) {
      **b = value.as<bool>();
    } else {
      SCENELOC_RETURN_IF_ERROR(CheckRange(f, value.as<double>(), value.as<std::string>(), where));
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

}  // namespace

std::string SettingField::FlagName() const {
  if (!flag.empty()) return flag;
  std::string dashed = key;
  std::replace(dashed.begin(), dashed.end(), '_', '-');
  return dashed;
}

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

StatusOr<std::string> ReadSettingsFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return NotFound("settings file '" + path + "' cannot be opened");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace sceneloc
