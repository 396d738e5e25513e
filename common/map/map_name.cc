#include "common/map/map_name.h"

#include <cctype>
#include <cstring>
#include <filesystem>

namespace sceneloc {

std::string MapNameProblem(const std::string& name) {
  if (name.empty()) return "a map name must not be empty";
  if (name.size() > 255) return "a map name has at most 255 characters";
  if (name[0] == '.') return "a map name must not start with '.'";
  for (const char c : name) {
    const bool ok = std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
    if (!ok) return "a map name holds only letters, digits, '_', '-' and '.'";
  }
  return "";
}

bool IsValidMapName(const std::string& name) { return MapNameProblem(name).empty(); }

std::string MapNameOfFile(const std::string& file_name) {
  const size_t extension = std::strlen(kMapFileExtension);
  if (file_name.size() <= extension ||
      file_name.compare(file_name.size() - extension, extension, kMapFileExtension) != 0) {
    return "";
  }
  const std::string stem = file_name.substr(0, file_name.size() - extension);
  return IsValidMapName(stem) ? stem : "";
}

std::string MapFilePath(const std::string& maps_dir, const std::string& name) {
  return (std::filesystem::path(maps_dir) / (name + kMapFileExtension)).string();
}

}  // namespace sceneloc
