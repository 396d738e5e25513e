#include "common/map/map_file_io.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include "common/map/crc32.h"
#include "common/map/map_header.h"

namespace sceneloc::map_io_internal {

StatusOr<size_t> ReadPrefix(int fd, char* out, size_t n, const std::string& path) {
  size_t done = 0;
  while (done < n) {
    const ssize_t got = ::read(fd, out + done, n - done);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) return OsError("cannot read map file", path, errno);
    if (got == 0) break;
    done += static_cast<size_t>(got);
  }
  return done;
}

Status FileSource::Read(void* out, size_t n) {
  char* to = static_cast<char*>(out);
  const size_t from_buffer = std::min(n, end_ - begin_);
  if (from_buffer > 0) std::memcpy(to, buffer_.data() + begin_, from_buffer);
  begin_ += from_buffer;
  size_t done = from_buffer;
  if (done < n && n - done >= buffer_.size()) {  // large: no copy through the buffer
    SCENELOC_RETURN_IF_ERROR(ReadFully(to + done, n - done));
    done = n;
  }
  while (done < n) {
    SCENELOC_RETURN_IF_ERROR(Refill());
    const size_t take = std::min(n - done, end_ - begin_);
    std::memcpy(to + done, buffer_.data() + begin_, take);
    begin_ += take;
    done += take;
  }
  crc_ = Crc32(out, n, crc_);
  return Status::Ok();
}

Status FileSource::Skip(size_t n) {
  while (n > 0) {
    const size_t take = std::min(n, buffer_.size());
    SCENELOC_RETURN_IF_ERROR(Read(scratch_.data(), take));
    n -= take;
  }
  return Status::Ok();
}

Status FileSource::Refill() {
  begin_ = 0;
  end_ = 0;
  for (;;) {
    const ssize_t got = ::read(fd_, buffer_.data(), buffer_.size());
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) return OsError("cannot read map file", path_, errno);
    if (got == 0) return Shrunk();
    end_ = static_cast<size_t>(got);
    return Status::Ok();
  }
}

Status FileSource::ReadFully(char* to, size_t n) {
  while (n > 0) {
    const ssize_t got = ::read(fd_, to, std::min<size_t>(n, 1 << 30));
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) return OsError("cannot read map file", path_, errno);
    if (got == 0) return Shrunk();
    to += got;
    n -= static_cast<size_t>(got);
  }
  return Status::Ok();
}

Status FileSource::Shrunk() const {
  return DataLoss(Label(path_) + " is truncated: it ended before its payload did (was it " +
                  "being written or truncated while it was read?)");
}

FdCloser::~FdCloser() { ::close(fd_); }

}  // namespace sceneloc::map_io_internal
