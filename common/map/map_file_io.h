// The file system side of map_io (map_io.h): writing a file so that it holds either its
// old content or the whole new one, and reading a map file's payload as it is parsed,
// with its CRC-32. Internal to map_io.
//
// Thread-safe: free functions without shared state; a FileSource is used by one thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/map/payload_archive.h"
#include "common/util/file_io.h"  // WriteFileAtomically, OsError
#include "common/util/status.h"

namespace sceneloc::map_io_internal {

// Reads up to `n` bytes from `fd`'s current position (fewer if the file ends first).
// `path` names the file in errors.
StatusOr<size_t> ReadPrefix(int fd, char* out, size_t n, const std::string& path);

// A map file's payload read as it is parsed: small fields through a 64 KiB buffer, arrays
// straight into their destination; the CRC-32 of every byte delivered is kept. A file
// that ends early is DataLoss (it was truncated while it was read). Does not own `fd`.
class FileSource : public ByteSource {
 public:
  FileSource(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}

  Status Read(void* out, size_t n) override;
  // Reads and checksums `n` more bytes without keeping them.
  Status Skip(size_t n);
  // CRC-32 of every byte read or skipped so far.
  uint32_t crc() const { return crc_; }

 private:
  Status Refill();
  Status ReadFully(char* to, size_t n);
  Status Shrunk() const;

  int fd_;
  std::string path_;
  std::vector<char> buffer_ = std::vector<char>(64 * 1024);
  std::vector<char> scratch_ = std::vector<char>(64 * 1024);
  size_t begin_ = 0, end_ = 0;
  uint32_t crc_ = 0;
};

// Closes a file descriptor on every path out.
class FdCloser {
 public:
  explicit FdCloser(int fd) : fd_(fd) {}
  ~FdCloser();
  FdCloser(const FdCloser&) = delete;
  FdCloser& operator=(const FdCloser&) = delete;

 private:
  int fd_;
};

}  // namespace sceneloc::map_io_internal
