// Watches the maps directory for map files that appear, are replaced or disappear, with
// Linux inotify (the kernel queues the events; nothing is polled on disk).
//
// Events: IN_CLOSE_WRITE (a file written in place is complete), IN_MOVED_TO (a file
// renamed into place: SaveMap's atomic replace), IN_DELETE and IN_MOVED_FROM (a file gone).
// Only names MapNameOfFile (common/map/map_name.h) accepts count: SaveMap's temporary
// "x.scnl.tmp.<pid>" and hidden files are ignored, so a half-written file is never seen under its
// final name.
//
// Not thread-safe: one thread owns a watcher (the map loader's).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "common/map/map_name.h"
#include "common/util/status.h"

namespace sceneloc {

// One change to a map file, named by its map (the file stem).
struct MapFileEvent {
  std::string map;
  bool removed = false;  // IN_DELETE / IN_MOVED_FROM; else written or renamed into place
};

class DirWatcher {
 public:
  // Starts watching `dir`. Errors: IoError naming `dir` and the OS error (no such
  // folder, or the inotify limits reached).
  static StatusOr<std::unique_ptr<DirWatcher>> Open(const std::string& dir);
  ~DirWatcher();
  DirWatcher(const DirWatcher&) = delete;
  DirWatcher& operator=(const DirWatcher&) = delete;

  // A non-blocking descriptor that is readable (POLLIN) when events are queued.
  int fd() const { return fd_; }

  // Takes every event queued now, in order, without blocking. *overflowed is set when the
  // kernel's queue overflowed and events were lost (the caller should rescan the
  // folder); *lost when the folder itself was deleted or moved (no more events will come).
  std::vector<MapFileEvent> ReadEvents(bool* overflowed, bool* lost);

 private:
  explicit DirWatcher(int fd) : fd_(fd) {}
  const int fd_;
};

}  // namespace sceneloc
