// A test's own folder of real files on disk, and the few file helpers tests share.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace sceneloc::test {

// A fresh, empty folder under gtest's temp dir, named after the process, the running test
// and `tag`, so tests run in parallel never share one; removed with everything in it by
// the destructor. Not thread-safe (one per test).
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& tag = "scratch");
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  // (path() / name) as a string; nothing is created.
  std::string File(const std::string& name) const;

 private:
  std::filesystem::path path_;
};

// Writes `bytes` to `path`, replacing what was there; gtest-nonfatal failure when it cannot.
void WriteFileBytes(const std::string& path, const std::string& bytes);
// The whole file; empty when it cannot be read.
std::string ReadFileBytes(const std::string& path);
// The names of the entries of `dir`, sorted.
std::vector<std::string> DirectoryEntries(const std::filesystem::path& dir);

}  // namespace sceneloc::test
