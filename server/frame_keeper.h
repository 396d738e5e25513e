// Material for the next experience (docs/experiences.md): the frames of robots' sessions
// that stayed UNKNOWN for several frames in a row — where the map failed — kept on disk, per
// map, within a quota, so that an operator can fetch them and extend the map with them
// (`sceneloc frames fetch`, then `sceneloc-train --extend`). Off unless keep_frames.dir is
// set: the server then stores other people's camera frames, which an operator must ask for.
//
// What is kept: JPEG frames of requests that name a session (a feature set cannot be trained
// from). A session's streak counts its frames whose session answer is UNKNOWN; once it
// reaches min_unknown_frames, those frames (held in memory until then) and every following
// UNKNOWN frame are written, as one *run*, until the session is LOCALISED again or resets.
// Each run remembers the session's last LOCALISED answer before it (its anchor: where the
// robot last knew it was).
//
// On disk, under keep_frames.dir:
//   <map>/<run>/000000.jpg, 000001.jpg, ...   the frames, exactly the bytes the robot sent
//   <map>/<run>.yaml                           the run: session, client key, map checksum,
//                                              anchor, and each frame's time and answers
// <run> is "<UTC start>-<session>" (the session name with anything but [A-Za-z0-9_.-] as
// '_'). The run folder holds only images, so `sceneloc-train --extend MAP --tour
// <map>/<run>` reads it as it is. Every file is written whole (file_io.h), so a crash leaves
// a run without its last frame, never a torn one; the folder and its usage survive a restart.
//
// Never beyond the quota: a frame whose bytes would pass keep_frames.quota_bytes (all maps
// together, counted from the files at start and from every write since) is dropped and
// counted. Frames wait in memory (before their streak is long enough, or for the writer
// thread) within keep_frames.max_pending_bytes; beyond it they are dropped and counted.
// Writes happen on the keeper's own thread: a reply never waits for the disk.
//
// Thread-safe: every method may run on any number of threads at once. frame_keeper.cc holds
// the streaks and the writer, kept_runs.cc the reading side (list, fetch, delete).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>
#include <vector>

#include "common/util/mutex.h"
#include "common/util/settings.h"
#include "common/util/status.h"
#include "common/util/thread_annotations.h"

namespace sceneloc {

struct KeepFramesOptions {
  // Folder the frames are kept in (created if missing). Empty: no frame is kept.
  std::string dir;
  // All kept files together at most, bytes.
  int64_t quota_bytes = int64_t{1} << 30;
  // UNKNOWN session answers in a row before a session's frames are kept (the first of them
  // included).
  int min_unknown_frames = 5;
  // Frames waiting in memory (streaks not yet long enough, writes queued) at most, bytes.
  int64_t max_pending_bytes = int64_t{64} << 20;

  Status Validate() const;
};

// The keep_frames: section, bound to `o`.
SettingTable KeepFramesSettings(KeepFramesOptions* o);

// What the keeper is told of one answered frame of a session.
struct SessionFrame {
  std::string client;   // the client's key name (empty without auth)
  std::string map;      // the map's name
  std::string session;  // the session's name
  bool reset = false;   // the request reset its session
  uint32_t map_checksum = 0;
  std::string_view jpeg;  // the frame as sent; empty for a feature set (never kept)
  int frame_place = -1;   // the frame's own best place and confidence
  double frame_confidence = 0;
  int session_place = -1;  // the session's answer
  std::string session_place_name;
  double session_probability = 0;
  double off_map = 0;
  bool localised = false;  // the session's decision
};

// One run as listed.
struct KeptRun {
  std::string map;
  std::string run;
  std::string session;
  std::string client;
  std::string started_utc;
  std::string last_utc;  // the last frame's
  int frames = 0;
  int64_t bytes = 0;  // its frames and record
  uint32_t map_checksum = 0;
  // The session's last LOCALISED answer before the run (place -1: none since it began).
  int anchor_place = -1;
  std::string anchor_name;
  double anchor_probability = 0;
  std::string anchor_utc;
};

struct KeptFrame {
  int index = 0;
  std::string file;  // "000012.jpg"
  std::string utc;
  std::string jpeg;
};

struct KeptPage {
  KeptRun run;
  std::vector<KeptFrame> frames;  // from the first asked for, in order
  int next_frame = 0;             // the first frame of the next page; run.frames when done
  std::string record;             // the run's record file, as kept (YAML)
};

struct KeepFramesCounts {
  int64_t bytes_used = 0;
  int64_t quota_bytes = 0;
  int64_t pending_bytes = 0;
  uint64_t kept = 0;            // frames written since start
  uint64_t dropped_quota = 0;   // frames not kept: the quota was full
  uint64_t dropped_memory = 0;  // frames not kept: max_pending_bytes was full
  uint64_t write_failures = 0;  // frames not kept: the disk refused (logged)
};

class FrameKeeper {
 public:
  using SystemClock = std::chrono::system_clock;

  // Creates options.dir if missing, checks that it can be written, counts what it holds
  // (removing the temporary files of writes a crash cut short) and starts the writer.
  // Errors: options invalid or empty dir (InvalidArgument), the folder cannot be made or
  // written (IoError naming it).
  static StatusOr<std::unique_ptr<FrameKeeper>> Open(const KeepFramesOptions& options);
  // Writes what is queued, then stops.
  ~FrameKeeper();
  FrameKeeper(const FrameKeeper&) = delete;
  FrameKeeper& operator=(const FrameKeeper&) = delete;

  // Counts `frame` into its session's streak and keeps it when the streak says so (the
  // write itself is queued). Frames of one session must come one after the other.
  void Observe(const SessionFrame& frame, SystemClock::time_point now) EXCLUDES(mutex_);

  // The runs of `map` (every map when empty), by map and then by start. NotFound for a
  // map name that has no runs.
  StatusOr<std::vector<KeptRun>> List(const std::string& map) const EXCLUDES(io_mutex_);
  // Frames of one run from `first_frame`, as many as fit in `max_bytes` (at least one).
  // NotFound for a run that does not exist, InvalidArgument for a malformed name or a
  // first_frame past its end.
  StatusOr<KeptPage> Fetch(const std::string& map, const std::string& run, int first_frame,
                           int64_t max_bytes) const EXCLUDES(io_mutex_);
  // Removes a run (its frames and record, even a damaged record) and frees its bytes; a
  // session still writing it starts a new run with its next kept frame. Returns the run as it
  // was listed (its names alone when its record could not be read).
  StatusOr<KeptRun> Delete(const std::string& map, const std::string& run)
      EXCLUDES(mutex_, io_mutex_, usage_mutex_);

  // Waits until every write queued so far is done.
  void Flush() EXCLUDES(mutex_);
  KeepFramesCounts Counts() const EXCLUDES(mutex_, usage_mutex_);
  const KeepFramesOptions& options() const { return options_; }

 private:
  struct FrameRecord {
    std::string file;
    std::string utc;
    int frame_place = -1;
    double frame_confidence = 0;
    int session_place = -1;
    double session_probability = 0;
    double off_map = 0;
  };
  struct Pending {
    std::string jpeg;
    FrameRecord record;
  };
  // A session's streak and, while one is open, its run.
  struct Tracker {
    int streak = 0;
    std::deque<Pending> pending;  // the streak's frames until it is long enough
    std::string run;              // the open run; empty = none
    KeptRun info;                 // the open run's record
    std::vector<FrameRecord> records;
    int64_t record_bytes = 0;  // the record file as last queued
    SystemClock::time_point last_seen;
  };
  struct Write {
    std::string map, run;
    std::string frame_file;
    std::string jpeg;
    std::string record;    // the run's whole record after this frame
    int64_t reserved = 0;  // quota bytes held for it
  };

  FrameKeeper(const KeepFramesOptions& options, int64_t bytes_used);
  // The run's record file: what it is and each frame's answers, in the order kept.
  static std::string RunRecord(const KeptRun& run, const std::vector<FrameRecord>& frames);
  void WriterLoop() EXCLUDES(mutex_);
  void DoWrite(const Write& write) EXCLUDES(io_mutex_, usage_mutex_);
  // Opens a run for `t` (named from `frame` and `now`) and queues its pending frames.
  void OpenRun(Tracker* t, const SessionFrame& frame, SystemClock::time_point now) REQUIRES(mutex_);
  // Queues one frame of `t`'s open run, within the quota and the memory (else counts it dropped).
  void QueueFrame(Tracker* t, Pending frame) REQUIRES(mutex_);
  void EndStreak(Tracker* t) REQUIRES(mutex_);
  void Sweep(SystemClock::time_point now) REQUIRES(mutex_);
  bool Reserve(int64_t bytes) EXCLUDES(usage_mutex_);
  void Release(int64_t bytes) EXCLUDES(usage_mutex_);
  // A run from its record file; its frames' records and the file's text when asked for.
  StatusOr<KeptRun> ReadRun(const std::string& map, const std::string& run,
                            std::vector<FrameRecord>* frames, std::string* record = nullptr) const
      REQUIRES(io_mutex_);

  const KeepFramesOptions options_;

  mutable Mutex mutex_;  // trackers, the write queue and the pending memory
  std::unordered_map<std::string, Tracker> trackers_ GUARDED_BY(mutex_);
  std::deque<Write> queue_ GUARDED_BY(mutex_);
  std::condition_variable queue_changed_;
  bool writing_ GUARDED_BY(mutex_) = false;  // the writer holds a write taken off the queue
  bool stopping_ GUARDED_BY(mutex_) = false;
  int64_t pending_bytes_ GUARDED_BY(mutex_) = 0;
  uint64_t dropped_memory_ GUARDED_BY(mutex_) = 0;
  SystemClock::time_point last_sweep_ GUARDED_BY(mutex_);
  std::string last_run_ GUARDED_BY(mutex_);  // names are unique even within one second

  mutable Mutex usage_mutex_;
  int64_t bytes_used_ GUARDED_BY(usage_mutex_) = 0;
  uint64_t kept_ GUARDED_BY(usage_mutex_) = 0;
  uint64_t dropped_quota_ GUARDED_BY(usage_mutex_) = 0;
  uint64_t write_failures_ GUARDED_BY(usage_mutex_) = 0;

  // Held for each file operation, so that listing, fetching and deleting see whole runs.
  mutable Mutex io_mutex_;

  std::thread writer_;
};

// The run's record file beside its folder: <map>/<run><kRunRecordSuffix>.
inline constexpr char kRunRecordSuffix[] = ".yaml";

// Whether `name` could be a run's name: 1..160 of [A-Za-z0-9_.-], not starting with '.'.
bool IsValidRunName(const std::string& name);

}  // namespace sceneloc
