#include "server/frame_keeper.h"

#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <system_error>

#include "common/util/file_io.h"
#include "common/util/utc_time.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

// Sessions not seen for this long are forgotten (their streak with them), seconds: the
// server's default session idle timeout.
constexpr auto kTrackerIdle = std::chrono::seconds(600);
// Sessions tracked at most; past it the least recently seen is forgotten.
constexpr size_t kMaxTrackers = 10000;
// A run holds at most this many frames; a longer streak goes on in a new run (its record is
// rewritten with every frame).
constexpr int kMaxRunFrames = 2000;

// A run's name starts with the UTC second it opened.
constexpr char kRunTimeFormat[] = "%Y%m%dT%H%M%SZ";

// The session's name as a file name's part.
std::string SafeName(const std::string& session) {
  std::string out = session.substr(0, 64);
  for (char& c : out) {
    const bool plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                       c == '_' || c == '-' || c == '.';
    if (!plain) c = '_';
  }
  return out;
}

std::string FrameFile(int index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.jpg", index);
  return name;
}

std::string TrackerKey(const SessionFrame& f) { return f.client + '\0' + f.map + '\0' + f.session; }

}  // namespace

SettingTable KeepFramesSettings(KeepFramesOptions* o) {
  return {
      Setting("keep_frames", "dir", &o->dir)
          .Help("folder that keeps the frames of sessions the map failed on, for the next "
                "experience (docs/experiences.md); empty: none kept")
          .Flag("keep-frames"),
      Setting("keep_frames", "quota_bytes", &o->quota_bytes)
          .Range(1, 1e15)
          .Unit("bytes")
          .Help("kept files together at most; a frame past it is dropped")
          .Flag("keep-frames-quota"),
      Setting("keep_frames", "min_unknown_frames", &o->min_unknown_frames)
          .Range(1, 1000)
          .Help("UNKNOWN session answers in a row before the session's frames are kept")
          .Flag("keep-frames-after"),
      Setting("keep_frames", "max_pending_bytes", &o->max_pending_bytes)
          .Range(1, 1e12)
          .Unit("bytes")
          .Help("frames waiting in memory (short streaks, queued writes) at most")
          .Flag("keep-frames-memory"),
  };
}

Status KeepFramesOptions::Validate() const {
  KeepFramesOptions copy = *this;
  return CheckSettings(KeepFramesSettings(&copy));
}

bool IsValidRunName(const std::string& name) {
  if (name.empty() || name.size() > 160 || name[0] == '.') return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.';
  });
}

namespace {

// Sums the kept files under `dir` and removes the temporary files of cut-short writes.
StatusOr<int64_t> ScanUsage(const fs::path& dir) {
  std::error_code ec;
  int64_t bytes = 0;
  int removed = 0;
  for (auto it = fs::recursive_directory_iterator(dir, ec); !ec && it != fs::end(it);
       it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    if (it->path().filename().string().find(".tmp.") != std::string::npos) {
      fs::remove(it->path(), ec);
      ++removed;
      continue;
    }
    bytes += static_cast<int64_t>(it->file_size(ec));
  }
  if (ec) return IoError("cannot read keep_frames.dir '" + dir.string() + "': " + ec.message());
  if (removed > 0)
    spdlog::warn("keep_frames: removed {} cut-short write(s) under {}", removed, dir.string());
  return bytes;
}

void EmitRun(YAML::Emitter* out, const KeptRun& run) {
  *out << YAML::Key << "map" << YAML::Value << run.map;
  *out << YAML::Key << "session" << YAML::Value << run.session;
  *out << YAML::Key << "client" << YAML::Value << run.client;
  *out << YAML::Key << "started_utc" << YAML::Value << run.started_utc;
  *out << YAML::Key << "map_checksum" << YAML::Value << run.map_checksum;
  *out << YAML::Key << "anchor" << YAML::Value << YAML::BeginMap;
  *out << YAML::Key << "place" << YAML::Value << run.anchor_place;
  *out << YAML::Key << "name" << YAML::Value << run.anchor_name;
  *out << YAML::Key << "probability" << YAML::Value << run.anchor_probability;
  *out << YAML::Key << "utc" << YAML::Value << run.anchor_utc;
  *out << YAML::EndMap;
}

}  // namespace

// The run's record: what it is and each frame's answers, in the order kept.
std::string FrameKeeper::RunRecord(const KeptRun& run, const std::vector<FrameRecord>& frames) {
  YAML::Emitter out;
  out << YAML::Comment(
      "A run of frames a sceneloc-server kept where its map failed (server/frame_keeper.h)");
  out << YAML::BeginMap;
  EmitRun(&out, run);
  out << YAML::Key << "frames" << YAML::Value << YAML::BeginSeq;
  for (const FrameRecord& f : frames) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "file" << YAML::Value << f.file;
    out << YAML::Key << "utc" << YAML::Value << f.utc;
    out << YAML::Key << "place" << YAML::Value << f.frame_place;
    out << YAML::Key << "confidence" << YAML::Value << f.frame_confidence;
    out << YAML::Key << "session_place" << YAML::Value << f.session_place;
    out << YAML::Key << "session_probability" << YAML::Value << f.session_probability;
    out << YAML::Key << "off_map" << YAML::Value << f.off_map;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

StatusOr<std::unique_ptr<FrameKeeper>> FrameKeeper::Open(const KeepFramesOptions& options) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  if (options.dir.empty()) return InvalidArgument("keep_frames.dir is not set");
  std::error_code ec;
  fs::create_directories(options.dir, ec);
  if (ec) return IoError("cannot make keep_frames.dir '" + options.dir + "': " + ec.message());
  const std::string probe = (fs::path(options.dir) / ".write-check").string();
  SCENELOC_RETURN_IF_ERROR(WriteFileAtomically(probe, "sceneloc\n"));
  fs::remove(probe, ec);
  SCENELOC_ASSIGN_OR_RETURN(const int64_t used, ScanUsage(options.dir));
  spdlog::info(
      "keep_frames: {} holds {:.1f} MB of {:.1f} MB; keeping JPEG frames after {} "
      "UNKNOWN session answers in a row",
      options.dir, used / 1e6, options.quota_bytes / 1e6, options.min_unknown_frames);
  return std::unique_ptr<FrameKeeper>(new FrameKeeper(options, used));
}

FrameKeeper::FrameKeeper(const KeepFramesOptions& options, int64_t bytes_used) : options_(options) {
  {
    MutexLock lock(&usage_mutex_);
    bytes_used_ = bytes_used;
  }
  writer_ = std::thread([this] { WriterLoop(); });
}

FrameKeeper::~FrameKeeper() {
  {
    MutexLock lock(&mutex_);
    stopping_ = true;
  }
  queue_changed_.notify_all();
  writer_.join();
}

bool FrameKeeper::Reserve(int64_t bytes) {
  MutexLock lock(&usage_mutex_);
  if (bytes_used_ + bytes > options_.quota_bytes) {
    ++dropped_quota_;
    return false;
  }
  bytes_used_ += bytes;
  return true;
}

void FrameKeeper::Release(int64_t bytes) {
  MutexLock lock(&usage_mutex_);
  bytes_used_ -= bytes;
}

void FrameKeeper::Observe(const SessionFrame& frame, SystemClock::time_point now) {
  MutexLock lock(&mutex_);
  Sweep(now);
  const std::string key = TrackerKey(frame);
  auto it = trackers_.find(key);
  if (it == trackers_.end()) {
    // A session is tracked from its first frame that counts or is worth remembering.
    if (!frame.localised && frame.jpeg.empty()) return;
    it = trackers_.emplace(key, Tracker()).first;
  }
  Tracker& t = it->second;
  t.last_seen = now;
  if (frame.reset) {
    EndStreak(&t);
    t.info = KeptRun();  // where it last knew it was no longer holds
  }
  if (frame.localised) {
    EndStreak(&t);
    t.info.anchor_place = frame.session_place;
    t.info.anchor_name = frame.session_place_name;
    t.info.anchor_probability = frame.session_probability;
    t.info.anchor_utc = UtcText(now);
    return;
  }
  if (frame.jpeg.empty()) return;  // a feature set: counted neither way
  ++t.streak;
  Pending p{std::string(frame.jpeg),
            {"", UtcText(now), frame.frame_place, frame.frame_confidence, frame.session_place,
             frame.session_probability, frame.off_map}};
  if (!t.run.empty() && static_cast<int>(t.records.size()) >= kMaxRunFrames) t.run.clear();
  if (!t.run.empty()) return QueueFrame(&t, std::move(p));
  const auto size = static_cast<int64_t>(p.jpeg.size());
  if (pending_bytes_ + size > options_.max_pending_bytes) {
    ++dropped_memory_;
  } else {
    pending_bytes_ += size;
    t.pending.push_back(std::move(p));
  }
  if (t.streak >= options_.min_unknown_frames) OpenRun(&t, frame, now);
}

void FrameKeeper::EndStreak(Tracker* t) {
  for (const Pending& p : t->pending) pending_bytes_ -= static_cast<int64_t>(p.jpeg.size());
  t->pending.clear();
  t->streak = 0;
  t->run.clear();
  t->records.clear();
  t->record_bytes = 0;
}

void FrameKeeper::OpenRun(Tracker* t, const SessionFrame& frame, SystemClock::time_point now) {
  const std::string base = UtcText(now, kRunTimeFormat) + "-" + SafeName(frame.session);
  std::string name = base;
  // Unique against what is on disk and what this process named in the same second.
  std::error_code ec;
  const fs::path map_dir = fs::path(options_.dir) / frame.map;
  for (int n = 2; name == last_run_ || fs::exists(map_dir / name, ec) ||
                  fs::exists(map_dir / (name + kRunRecordSuffix), ec);
       ++n) {
    name = base + "-" + std::to_string(n);
  }
  last_run_ = name;
  t->run = name;
  t->records.clear();
  t->record_bytes = 0;
  t->info.map = frame.map;
  t->info.run = name;
  t->info.session = frame.session;
  t->info.client = frame.client;
  t->info.started_utc = UtcText(now);
  t->info.map_checksum = frame.map_checksum;
  std::deque<Pending> pending;
  pending.swap(t->pending);
  for (Pending& p : pending) {
    pending_bytes_ -= static_cast<int64_t>(p.jpeg.size());
    QueueFrame(t, std::move(p));
  }
  spdlog::info(
      "keep_frames: session '{}' of map '{}' UNKNOWN {} frames in a row: keeping its "
      "frames as run {}",
      frame.session, frame.map, t->streak, name);
}

void FrameKeeper::QueueFrame(Tracker* t, Pending frame) {
  const auto jpeg_bytes = static_cast<int64_t>(frame.jpeg.size());
  if (pending_bytes_ + jpeg_bytes > options_.max_pending_bytes) {
    ++dropped_memory_;
    return;
  }
  frame.record.file = FrameFile(static_cast<int>(t->records.size()));
  t->records.push_back(frame.record);
  std::string record = RunRecord(t->info, t->records);
  const int64_t reserved = jpeg_bytes + static_cast<int64_t>(record.size()) - t->record_bytes;
  if (!Reserve(reserved)) {
    t->records.pop_back();
    return;
  }
  t->record_bytes = static_cast<int64_t>(record.size());
  pending_bytes_ += jpeg_bytes;
  queue_.push_back(
      {t->info.map, t->run, frame.record.file, std::move(frame.jpeg), std::move(record), reserved});
  queue_changed_.notify_all();
}

void FrameKeeper::Sweep(SystemClock::time_point now) {
  if (now - last_sweep_ < std::chrono::seconds(1) && trackers_.size() < kMaxTrackers) return;
  last_sweep_ = now;
  for (auto it = trackers_.begin(); it != trackers_.end();) {
    if (now - it->second.last_seen > kTrackerIdle) {
      EndStreak(&it->second);
      it = trackers_.erase(it);
    } else {
      ++it;
    }
  }
  while (trackers_.size() >= kMaxTrackers) {
    auto oldest = std::min_element(trackers_.begin(), trackers_.end(), [](auto& a, auto& b) {
      return a.second.last_seen < b.second.last_seen;
    });
    EndStreak(&oldest->second);
    trackers_.erase(oldest);
  }
}

void FrameKeeper::WriterLoop() {
  for (;;) {
    Write write;
    {
      MutexLock lock(&mutex_);
      while (queue_.empty() && !stopping_) lock.Wait(queue_changed_);
      if (queue_.empty()) return;  // stopping, with everything written
      write = std::move(queue_.front());
      queue_.pop_front();
      writing_ = true;
    }
    DoWrite(write);
    {
      MutexLock lock(&mutex_);
      pending_bytes_ -= static_cast<int64_t>(write.jpeg.size());
      writing_ = false;
    }
    queue_changed_.notify_all();
  }
}

void FrameKeeper::DoWrite(const Write& write) {
  MutexLock io(&io_mutex_);
  const fs::path map_dir = fs::path(options_.dir) / write.map;
  const fs::path run_dir = map_dir / write.run;
  std::error_code ec;
  fs::create_directories(run_dir, ec);
  Status status = ec ? OsError("cannot make", run_dir.string(), ec.value()) : Status::Ok();
  if (status.ok()) {
    status = WriteFileAtomically((run_dir / write.frame_file).string(), write.jpeg);
  }
  if (status.ok()) {
    status = WriteFileAtomically((map_dir / (write.run + kRunRecordSuffix)).string(), write.record);
  }
  MutexLock lock(&usage_mutex_);
  if (status.ok()) {
    ++kept_;
    return;
  }
  ++write_failures_;
  bytes_used_ -= static_cast<int64_t>(write.jpeg.size());  // the record's share may be on disk
  spdlog::error("keep_frames: frame {} of run {} not kept: {}", write.frame_file, write.run,
                status.message());
}

void FrameKeeper::Flush() {
  MutexLock lock(&mutex_);
  while (!queue_.empty() || writing_) lock.Wait(queue_changed_);
}

KeepFramesCounts FrameKeeper::Counts() const {
  KeepFramesCounts c;
  {
    MutexLock lock(&mutex_);
    c.pending_bytes = pending_bytes_;
    c.dropped_memory = dropped_memory_;
  }
  MutexLock lock(&usage_mutex_);
  c.bytes_used = bytes_used_;
  c.quota_bytes = options_.quota_bytes;
  c.kept = kept_;
  c.dropped_quota = dropped_quota_;
  c.write_failures = write_failures_;
  return c;
}

}  // namespace sceneloc
