#include "common/util/image_folder.h"

#include <algorithm>
#include <filesystem>

namespace sceneloc {

namespace fs = std::filesystem;

StatusOr<std::vector<std::string>> ListImageFiles(const std::string& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return NotFound("folder '" + dir + "' does not exist");
  if (!fs::is_directory(dir, ec)) return InvalidArgument("'" + dir + "' is not a folder");
  std::vector<std::string> files;
  fs::directory_iterator it(dir, ec);
  if (ec) return IoError("cannot read folder '" + dir + "': " + ec.message());
  for (const fs::directory_entry& entry : it) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name[0] == '.') continue;
    if (entry.is_regular_file(ec)) files.push_back(entry.path().string());
  }
  if (files.empty()) return FailedPrecondition("folder '" + dir + "' holds no image file");
  std::sort(files.begin(), files.end());
  return files;
}

std::string FileName(const std::string& path) { return fs::path(path).filename().string(); }

}  // namespace sceneloc
