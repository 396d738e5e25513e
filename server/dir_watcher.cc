#include "server/dir_watcher.h"

#include <sys/inotify.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "server/map_registry.h"

namespace sceneloc {
namespace {

constexpr uint32_t kChangedMask = IN_CLOSE_WRITE | IN_MOVED_TO;
constexpr uint32_t kRemovedMask = IN_DELETE | IN_MOVED_FROM;
constexpr uint32_t kLostMask = IN_DELETE_SELF | IN_MOVE_SELF | IN_IGNORED | IN_UNMOUNT;

}  // namespace

StatusOr<std::unique_ptr<DirWatcher>> DirWatcher::Open(const std::string& dir) {
  const int fd = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
  if (fd < 0) {
    return IoError("cannot watch maps directory '" + dir +
                   "': inotify_init1: " + std::strerror(errno));
  }
  // IN_ONLYDIR: a path that is not a folder is an error, not a watch on one file.
  // IN_DELETE_SELF and IN_MOVE_SELF must be asked for: without them a folder renamed away
  // is followed silently to its new name.
  if (inotify_add_watch(fd, dir.c_str(),
                        kChangedMask | kRemovedMask | IN_DELETE_SELF | IN_MOVE_SELF | IN_ONLYDIR) <
      0) {
    const int error = errno;
    ::close(fd);
    return IoError("cannot watch maps directory '" + dir + "': " + std::strerror(error));
  }
  return std::unique_ptr<DirWatcher>(new DirWatcher(fd));
}

DirWatcher::~DirWatcher() { ::close(fd_); }

std::vector<MapFileEvent> DirWatcher::ReadEvents(bool* overflowed, bool* lost) {
  *overflowed = false;
  *lost = false;
  std::vector<MapFileEvent> events;
  // Big enough for many events; the kernel never splits one across reads.
  alignas(inotify_event) char buffer[16 * (sizeof(inotify_event) + NAME_MAX + 1)];
  for (;;) {
    const ssize_t n = ::read(fd_, buffer, sizeof(buffer));
    if (n <= 0) break;  // EAGAIN: nothing more queued (or an error: try again next time)
    for (ssize_t at = 0; at < n;) {
      const auto* event = reinterpret_cast<const inotify_event*>(buffer + at);
      at += static_cast<ssize_t>(sizeof(inotify_event) + event->len);
      if (event->mask & IN_Q_OVERFLOW) *overflowed = true;
      if (event->mask & kLostMask) *lost = true;
      if (event->len == 0 || (event->mask & IN_ISDIR)) continue;
      const std::string map = MapNameOfFile(event->name);
      if (map.empty()) continue;
      if (event->mask & (kChangedMask | kRemovedMask)) {
        events.push_back({map, (event->mask & kRemovedMask) != 0});
      }
    }
  }
  return events;
}

}  // namespace sceneloc
