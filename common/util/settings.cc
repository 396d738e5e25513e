#include "common/util/settings.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <type_traits>
#include <utility>

namespace sceneloc {

SettingField Setting(std::string section, std::string key, SettingField::Target target) {
  SettingField f;
  f.section = std::move(section);
  f.key = std::move(key);
  f.target = target;
  return f;
}

SettingField&& SettingField::Range(double lo, double hi) && {
  min = lo;
  max = hi;
  return std::move(*this);
}

SettingField&& SettingField::Off(double value) && {
  has_off = true;
  off = value;
  return std::move(*this);
}

SettingField&& SettingField::Choices(std::vector<std::string> values) && {
  choices = std::move(values);
  return std::move(*this);
}

SettingField&& SettingField::Unit(std::string text) && {
  unit = std::move(text);
  return std::move(*this);
}

SettingField&& SettingField::Help(std::string text) && {
  help = std::move(text);
  return std::move(*this);
}

SettingField&& SettingField::Flag(std::string name) && {
  flag = std::move(name);
  return std::move(*this);
}

bool SettingField::is_number() const {
  return !std::holds_alternative<std::string*>(target) && !std::holds_alternative<bool*>(target);
}

std::string SettingField::FlagName() const {
  if (!flag.empty()) return flag;
  std::string dashed = key;
  std::replace(dashed.begin(), dashed.end(), '_', '-');
  return dashed;
}

std::string SettingField::Name() const { return section + "." + key; }

std::string FormatSettingNumber(double value) {
  // Whole numbers below 1e15 (exact in a double) print as integers, so that an integer
  // setting of 13 digits or more reads back as one; the largest range bounds stay short.
  if (std::isfinite(value) && std::abs(value) < 1e15 && value == std::trunc(value)) {
    return std::to_string(static_cast<int64_t>(value));
  }
  std::ostringstream out;
  out.precision(12);
  out << value;
  // strtod, not stod: stod throws out_of_range on a subnormal (ERANGE on underflow), and a
  // map file can carry any double (found by fuzz_map).
  if (std::isfinite(value) && std::strtod(out.str().c_str(), nullptr) != value) {
    out.str("");
    out.precision(17);  // enough for every double to read back exactly
    out << value;
  }
  return out.str();
}

std::string SettingField::Describe() const {
  if (std::holds_alternative<bool*>(target)) return "true | false";
  if (std::holds_alternative<std::string*>(target)) {
    std::string text;
    for (const std::string& c : choices) text += (text.empty() ? "" : " | ") + c;
    return text;
  }
  std::string text = "[" + FormatSettingNumber(min) + ", " + FormatSettingNumber(max) + "]";
  if (has_off) text = FormatSettingNumber(off) + " or " + text;
  if (!unit.empty()) text += " " + unit;
  return text;
}

bool InRange(const SettingField& field, double value) {
  if (!std::isfinite(value)) return false;
  if (field.has_off && value == field.off) return true;
  return value >= field.min && value <= field.max;
}

Status CheckSetting(const SettingField& field) {
  if (const auto* s = std::get_if<std::string*>(&field.target)) {
    const std::string& value = **s;
    if (field.choices.empty() ||
        std::find(field.choices.begin(), field.choices.end(), value) != field.choices.end()) {
      return Status::Ok();
    }
    return InvalidArgument(field.Name() + " = '" + value + "' is not one of " + field.Describe());
  }
  if (std::holds_alternative<bool*>(field.target)) return Status::Ok();
  const double value = std::visit(
      [](auto* p) -> double {
        using T = std::decay_t<decltype(*p)>;
        if constexpr (std::is_same_v<T, std::string>) {
          return 0;
        } else {
          return static_cast<double>(*p);
        }
      },
      field.target);
  if (InRange(field, value)) return Status::Ok();
  return InvalidArgument(field.Name() + " = " + FormatSettingNumber(value) + " is outside " +
                         field.Describe());
}

Status CheckSettings(const SettingTable& table) {
  for (const SettingField& field : table) SCENELOC_RETURN_IF_ERROR(CheckSetting(field));
  return Status::Ok();
}

}  // namespace sceneloc
