#include "common/util/file_io.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <system_error>

namespace sceneloc {
namespace {

// Writes all of `bytes` to `fd` and fsyncs it. `path` names the file in errors.
Status WriteAndSync(int fd, std::string_view bytes, const std::string& path) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return OsError("cannot write", path, errno);
    done += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0) return OsError("cannot fsync", path, errno);
  return Status::Ok();
}

// Makes a completed rename in `dir` durable.
Status SyncDirectory(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return OsError("cannot open directory", dir, errno);
  const int result = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  if (result != 0) return OsError("cannot fsync directory", dir, error);
  return Status::Ok();
}

// Writes `tmp` completely, or removes it and returns why not.
Status WriteTemporary(const std::string& tmp, std::string_view bytes) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return OsError("cannot create temporary file", tmp, errno);
  Status status = WriteAndSync(fd, bytes, tmp);
  if (::close(fd) != 0 && status.ok()) status = OsError("cannot close", tmp, errno);
  if (!status.ok()) ::unlink(tmp.c_str());
  return status;
}

}  // namespace

Status OsError(const std::string& what, const std::string& path, int error) {
  return IoError(what + " '" + path + "': " + std::strerror(error));
}

Status WriteFileAtomically(const std::string& path, std::string_view bytes) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  SCENELOC_RETURN_IF_ERROR(WriteTemporary(tmp, bytes));
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    ::unlink(tmp.c_str());
    return OsError("cannot rename '" + tmp + "' to", path, error);
  }
  std::string dir = std::filesystem::path(path).parent_path().string();
  return SyncDirectory(dir.empty() ? "." : dir);
}

StatusOr<std::string> ReadFileBytes(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return NotFound("'" + path + "' is not a readable file");
  }
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad() || !in.is_open()) return IoError("cannot read '" + path + "'");
  return bytes;
}

}  // namespace sceneloc
