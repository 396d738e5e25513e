#include "common/util/image_folder.h"

#include <algorithm>
#include <filesystem>

namespace sceneloc {

namespace fs = std::filesystem;

namespace {

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

}  // namespace

bool NaturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (IsDigit(a[i]) && IsDigit(b[j])) {
      // Two numbers: by value (fewer significant digits first), leading zeros skipped.
      size_t ai = i, bj = j;
      while (ai < a.size() && a[ai] == '0') ++ai;
      while (bj < b.size() && b[bj] == '0') ++bj;
      size_t ae = ai, be = bj;
      while (ae < a.size() && IsDigit(a[ae])) ++ae;
      while (be < b.size() && IsDigit(b[be])) ++be;
      if (ae - ai != be - bj) return ae - ai < be - bj;
      const int c = a.compare(ai, ae - ai, b, bj, be - bj);
      if (c != 0) return c < 0;
      i = ae;
      j = be;
    } else {
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  if (i < a.size() || j < b.size()) return j < b.size();  // a prefix of the other first
  return a < b;  // the same numbers written differently ("7" and "007"): a fixed order
}

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
  std::sort(files.begin(), files.end(), NaturalLess);
  return files;
}

std::string FileName(const std::string& path) { return fs::path(path).filename().string(); }

std::string FolderName(const std::string& dir) {
  const fs::path path = fs::path(dir).lexically_normal();
  std::string name = path.filename().string();
  if (name.empty()) name = path.parent_path().filename().string();
  return name.empty() ? dir : name;
}

}  // namespace sceneloc
