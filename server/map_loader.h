// The server's one map-loading thread: every load and unload after start-up runs here,
// never on a request worker or the I/O thread, so a slow load (reading, checksumming and
// self-testing a large map) occupies no thread that answers requests.
//
// Work arrives three ways, all handled in order on the loader thread:
//  - Reload(name, done): an admin ReloadMap request; `done` gets the result (the new
//    snapshot, or why the old one keeps serving) and sends the reply. Reloads of one map
//    that have not started yet coalesce into one load whose result answers them all; at
//    most Options::max_waiting_reloads wait at once, more are refused (kOverloaded), so
//    a flood of reloads costs one load, not a backlog;
//  - ReloadAll(): SIGHUP; reloads every map file in the folder and unloads the maps
//    whose file is gone (coalesced the same way);
//  - the watched folder (DirWatcher, when Options::watch): a map file written or renamed
//    into place is loaded; a deleted or renamed-away one is unloaded. Events for one name
//    are coalesced until it has been quiet for Options::debounce, and what is on disk
//    then decides: a file there is loaded, no file unloads the map. When the folder itself
//    is deleted, moved away or replaced, the loader says so, tries to watch maps_dir again
//    every Options::rewatch_interval, and once it can, rescans it (the maps of the folder
//    now at that path are served, the others unloaded).
//
// The loader runs one task, then the folder's events, then the next task: the watch is
// never starved by queued work. Stop() waits for one load at most.
//
// Every load goes through MapRegistry::Load (LoadMap + self-test, then an atomic swap), so
// a bad, truncated or half-written file changes nothing: the old map keeps serving, and
// the failure is logged (error), counted (MapRegistry::load_failures) and, for an admin
// request, returned. An unloaded map's snapshot lives until the requests holding it finish.
//
// Thread-safe: every public method may be called from any thread. `done` callbacks run on
// the loader thread, one at a time.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "common/util/mutex.h"
#include "common/util/status.h"
#include "common/util/thread_annotations.h"
#include "server/dir_watcher.h"
#include "server/map_registry.h"

namespace sceneloc {

class MapLoader {
 public:
  struct Options {
    // Folder holding the map files (<name>.scnl).
    std::string maps_dir;
    // Watch maps_dir with inotify and follow its changes.
    bool watch = true;
    // A name's file events are acted on once none has come for this long.
    std::chrono::milliseconds debounce{100};
    // Most Reload() callers waiting at once (coalesced ones included).
    size_t max_waiting_reloads = 16;
    // How often to try watching maps_dir again after the folder was lost.
    std::chrono::milliseconds rewatch_interval{1000};
  };
  enum class Queued {
    kQueued,      // `done` will run
    kOverloaded,  // max_waiting_reloads are already waiting; `done` dropped uncalled
    kStopping,    // Stop() has begun; `done` dropped uncalled
  };
  using LoadResult = StatusOr<std::shared_ptr<const LoadedMap>>;
  // Gets the load's result, or null when the loader stopped before starting it.
  using Done = std::function<void(const LoadResult* result)>;

  // Starts the loader thread (and the watch) for the maps of `registry`, which must
  // outlive the loader. Errors: IoError when the folder cannot be watched.
  static StatusOr<std::unique_ptr<MapLoader>> Start(const Options& options, MapRegistry* registry);
  ~MapLoader();  // Stop()s first
  MapLoader(const MapLoader&) = delete;
  MapLoader& operator=(const MapLoader&) = delete;

  // Queues a load of <maps_dir>/<map>.scnl, or joins one queued and not yet started;
  // `done` runs on the loader thread with the new snapshot or the error (or null if
  // Stop() comes first). See Queued for when `done` is dropped uncalled.
  // REQUIRES: `map` is a plain file stem (no '/', not starting with '.').
  Queued Reload(const std::string& map, Done done) EXCLUDES(mutex_);

  // Queues a reload of every map file in the folder (SIGHUP); maps served without a file
  // there any more are unloaded.
  void ReloadAll() EXCLUDES(mutex_);

  // Waits until everything queued, and every folder event the kernel had queued, before
  // the call has been acted on (debounce included). False at the timeout.
  bool WaitIdle(std::chrono::milliseconds timeout) EXCLUDES(mutex_);

  // Finishes the load in progress, answers the queued Reload()s with null, and
  // joins the thread. Idempotent.
  void Stop() EXCLUDES(stop_mutex_, mutex_);

 private:
  using Clock = std::chrono::steady_clock;
  struct Task {
    std::string map;         // empty: reload the whole folder
    std::vector<Done> done;  // every caller this load answers
  };

  MapLoader(const Options& options, MapRegistry* registry, int wake_fd,
            std::unique_ptr<DirWatcher> watcher);
  void Wake();
  void Loop() EXCLUDES(mutex_);
  std::optional<Task> NextTask() EXCLUDES(mutex_);  // null when none is queued or when stopping
  bool Stopping() const EXCLUDES(mutex_);
  int PollTimeoutMs() const EXCLUDES(mutex_);
  void ReadWatchEvents();
  void TryRewatch();
  void RescanFolder(Clock::time_point due);
  void RunDueFileChanges();
  void SyncFile(const std::string& map);
  void SyncFolder();
  void RunTask(Task& task);
  std::string PathOf(const std::string& map) const;

  // Constant after construction.
  const Options options_;
  MapRegistry* const registry_;
  const int wake_fd_;  // eventfd: Reload/ReloadAll/WaitIdle/Stop wake the loop

  // Loader thread only.
  std::unique_ptr<DirWatcher> watcher_;  // null when not watching (or the watch was lost)
  Clock::time_point rewatch_at_ = Clock::time_point::max();  // next attempt after a loss
  std::map<std::string, Clock::time_point> due_;  // map -> when to act on its file events

  mutable Mutex mutex_;
  std::condition_variable idle_cv_;  // signalled when idle_seen_ grows, and at Stop()
  // Guarded by mutex_.
  std::deque<Task> tasks_ GUARDED_BY(mutex_);  // at most one per map (and one folder task)
  size_t waiting_ GUARDED_BY(mutex_) = 0;      // Done callbacks in tasks_
  bool stopping_ GUARDED_BY(mutex_) = false;
  uint64_t idle_wanted_ GUARDED_BY(mutex_) = 0;  // WaitIdle calls so far
  // WaitIdle calls whose events and tasks are all handled.
  uint64_t idle_seen_ GUARDED_BY(mutex_) = 0;

  // Serialises Stop() calls; taken before mutex_.
  Mutex stop_mutex_ ACQUIRED_BEFORE(mutex_);
  std::thread thread_ GUARDED_BY(stop_mutex_);  // the loader thread
};

}  // namespace sceneloc
