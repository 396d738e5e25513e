#include "server/map_loader.h"

#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <optional>
#include <set>

#include "common/util/timer.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

// The names of the map files in `dir` now (empty when it cannot be listed).
std::set<std::string> MapFilesIn(const std::string& dir) {
  std::set<std::string> maps;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string map = MapNameOfFile(it->path().filename().string());
    if (!map.empty() && it->is_regular_file(ec)) maps.insert(map);
  }
  return maps;
}

// Loads `path` into the registry, timed, and logs the outcome.
MapLoader::LoadResult LoadAndLog(const std::string& why, const std::string& map,
                                 const std::string& path, MapRegistry* registry) {
  Stopwatch watch;
  MapLoader::LoadResult result = registry->Load(path);
  if (result.ok()) {
    const LoadedMap& m = **result;
    spdlog::info(
        "{}: map {} generation {} checksum {:08x} now serving ({} locations, {:.1f} MB in memory, "
        "{}) after {:.0f} ms",
        why, m.name, m.generation, m.checksum, m.map.num_places(), m.map.MemoryBytes() / 1e6,
        m.path, watch.Milliseconds());
  } else {
    spdlog::error("{}: map {} not reloaded, the version serving (if any) stays: {}", why, map,
                  result.status().ToString());
  }
  return result;
}

}  // namespace

StatusOr<std::unique_ptr<MapLoader>> MapLoader::Start(const Options& options,
                                                      MapRegistry* registry) {
  std::unique_ptr<DirWatcher> watcher;
  if (options.watch) {
    auto opened = DirWatcher::Open(options.maps_dir);
    if (!opened.ok()) return opened.status();
    watcher = std::move(opened).value();
  }
  const int wake_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd < 0) return IoError(std::string("map loader: eventfd: ") + std::strerror(errno));
  std::unique_ptr<MapLoader> loader(new MapLoader(options, registry, wake_fd, std::move(watcher)));
  {
    MutexLock lock(&loader->stop_mutex_);
    loader->thread_ = std::thread([l = loader.get()] { l->Loop(); });
  }
  return loader;
}

MapLoader::MapLoader(const Options& options, MapRegistry* registry, int wake_fd,
                     std::unique_ptr<DirWatcher> watcher)
    : options_(options), registry_(registry), wake_fd_(wake_fd), watcher_(std::move(watcher)) {}

MapLoader::~MapLoader() {
  Stop();
  ::close(wake_fd_);
}

void MapLoader::Wake() {
  const uint64_t one = 1;
  // Fails only when the counter is saturated, which already means "wake up".
  (void)!::write(wake_fd_, &one, sizeof(one));
}

MapLoader::Queued MapLoader::Reload(const std::string& map, Done done) {
  {
    MutexLock lock(&mutex_);
    if (stopping_) return Queued::kStopping;
    if (waiting_ >= options_.max_waiting_reloads) return Queued::kOverloaded;
    ++waiting_;
    const auto same = std::find_if(tasks_.begin(), tasks_.end(),
                                   [&](const Task& task) { return task.map == map; });
    if (same != tasks_.end()) {
      same->done.push_back(std::move(done));
      return Queued::kQueued;  // the loop is already due to run it
    }
    tasks_.push_back({map, {}});
    tasks_.back().done.push_back(std::move(done));
  }
  Wake();
  return Queued::kQueued;
}

void MapLoader::ReloadAll() {
  {
    MutexLock lock(&mutex_);
    if (stopping_) return;
    const bool queued = std::any_of(tasks_.begin(), tasks_.end(),
                                    [](const Task& task) { return task.map.empty(); });
    if (queued) return;
    tasks_.push_back({"", {}});
  }
  Wake();
}

bool MapLoader::WaitIdle(std::chrono::milliseconds timeout) {
  MutexLock lock(&mutex_);
  const uint64_t wanted = ++idle_wanted_;
  Wake();
  const Clock::time_point deadline = Clock::now() + timeout;
  while (idle_seen_ < wanted && !stopping_) {
    if (!lock.WaitUntil(idle_cv_, deadline)) break;
  }
  return idle_seen_ >= wanted;
}

void MapLoader::Stop() {
  MutexLock stop_lock(&stop_mutex_);
  if (!thread_.joinable()) return;
  {
    MutexLock lock(&mutex_);
    stopping_ = true;
  }
  Wake();
  thread_.join();
  idle_cv_.notify_all();
}

std::string MapLoader::PathOf(const std::string& map) const {
  return MapFilePath(options_.maps_dir, map);
}

// --- loader thread ---

void MapLoader::Loop() {
  for (;;) {
    pollfd fds[2] = {{wake_fd_, POLLIN, 0}, {watcher_ ? watcher_->fd() : -1, POLLIN, 0}};
    if (::poll(fds, 2, PollTimeoutMs()) < 0 && errno != EINTR) {
      spdlog::error("map loader: poll: {}", std::strerror(errno));
    }
    uint64_t ignored;
    (void)!::read(wake_fd_, &ignored, sizeof(ignored));

    uint64_t idle_wanted;
    {
      MutexLock lock(&mutex_);
      if (stopping_) break;
      idle_wanted = idle_wanted_;  // taken before the events are read: they count
    }
    ReadWatchEvents();
    TryRewatch();
    RunDueFileChanges();
    // One task per turn: the folder's events are read between tasks, and Stop() waits
    // for one load at most.
    if (std::optional<Task> task = NextTask()) RunTask(*task);

    MutexLock lock(&mutex_);
    if (due_.empty() && tasks_.empty() && idle_seen_ < idle_wanted) {
      idle_seen_ = idle_wanted;
      idle_cv_.notify_all();
    }
  }
  std::deque<Task> cancelled;
  {
    MutexLock lock(&mutex_);
    cancelled.swap(tasks_);
  }
  for (Task& task : cancelled) {
    for (Done& done : task.done) done(nullptr);
  }
}

int MapLoader::PollTimeoutMs() const {
  {
    MutexLock lock(&mutex_);
    if (!tasks_.empty() || stopping_) return 0;  // more work queued: do not sleep
  }
  Clock::time_point next = rewatch_at_;
  if (due_.empty() && next == Clock::time_point::max()) return -1;
  for (const auto& entry : due_) next = std::min(next, entry.second);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(next - Clock::now());
  // Rounded up, so the wake-up is never early.
  return static_cast<int>(std::max<int64_t>(0, ms.count() + 1));
}

void MapLoader::ReadWatchEvents() {
  if (!watcher_) return;
  bool overflowed = false, lost = false;
  const Clock::time_point due = Clock::now() + options_.debounce;
  for (const MapFileEvent& event : watcher_->ReadEvents(&overflowed, &lost)) {
    spdlog::debug("maps directory: {}{} {}", event.map, kMapFileExtension,
                  event.removed ? "removed" : "written");
    due_[event.map] = due;
  }
  if (overflowed) {
    spdlog::warn("maps directory {}: inotify queue overflowed; rescanning it", options_.maps_dir);
    RescanFolder(due);
  }
  if (lost) {
    spdlog::error(
        "maps directory {} was deleted, moved or replaced: watching for a folder at that path "
        "again every {} ms (SIGHUP and ReloadMap still reload)",
        options_.maps_dir, options_.rewatch_interval.count());
    watcher_.reset();
    rewatch_at_ = Clock::now();
  }
}

// Events were lost, or the folder changed under the watch: look at every file there is
// and every map served, and let what is on disk decide.
void MapLoader::RescanFolder(Clock::time_point due) {
  for (const std::string& map : MapFilesIn(options_.maps_dir)) due_[map] = due;
  for (const auto& loaded : registry_->List()) due_[loaded->name] = due;
}

void MapLoader::TryRewatch() {
  if (watcher_ || rewatch_at_ > Clock::now()) return;
  auto watcher = DirWatcher::Open(options_.maps_dir);
  if (!watcher.ok()) {
    rewatch_at_ = Clock::now() + options_.rewatch_interval;
    return;
  }
  watcher_ = std::move(watcher).value();
  rewatch_at_ = Clock::time_point::max();
  spdlog::info("maps directory {}: watching it again; rescanning", options_.maps_dir);
  RescanFolder(Clock::now() + options_.debounce);
}

std::optional<MapLoader::Task> MapLoader::NextTask() {
  MutexLock lock(&mutex_);
  if (stopping_ || tasks_.empty()) return std::nullopt;
  Task task = std::move(tasks_.front());
  tasks_.pop_front();
  waiting_ -= task.done.size();
  return task;
}

bool MapLoader::Stopping() const {
  MutexLock lock(&mutex_);
  return stopping_;
}

void MapLoader::RunDueFileChanges() {
  const Clock::time_point now = Clock::now();
  for (auto it = due_.begin(); it != due_.end() && !Stopping();) {
    if (it->second > now) {
      ++it;
      continue;
    }
    const std::string map = it->first;
    it = due_.erase(it);
    SyncFile(map);
  }
}

// Makes the map `map` follow its file: loaded when there is one, unloaded when not.
void MapLoader::SyncFile(const std::string& map) {
  const std::string path = PathOf(map);
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) {
    static_cast<void>(LoadAndLog("file changed", map, path, registry_));  // it logs the outcome
    return;
  }
  if (registry_->Remove(map)) {
    spdlog::info("file removed: map {} unloaded (requests holding it finish on it)", map);
  }
}

void MapLoader::SyncFolder() {
  spdlog::info("reloading every map in {}", options_.maps_dir);
  const std::set<std::string> files = MapFilesIn(options_.maps_dir);
  for (const std::string& map : files) {
    if (Stopping()) return;
    static_cast<void>(
        LoadAndLog("reload all", map, PathOf(map), registry_));  // it logs the outcome
  }
  for (const auto& loaded : registry_->List()) {
    if (files.count(loaded->name) == 0) SyncFile(loaded->name);
  }
}

void MapLoader::RunTask(Task& task) {
  if (task.map.empty()) return SyncFolder();
  LoadResult result = LoadAndLog(
      task.done.size() > 1 ? "ReloadMap (" + std::to_string(task.done.size()) + " coalesced)"
                           : std::string("ReloadMap"),
      task.map, PathOf(task.map), registry_);
  for (Done& done : task.done) {
    if (done) done(&result);
  }
}

}  // namespace sceneloc
