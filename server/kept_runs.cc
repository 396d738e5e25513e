// FrameKeeper's reading side: the runs on disk listed, fetched and deleted.
#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>
#include <system_error>

#include "common/map/map_name.h"
#include "common/util/file_io.h"
#include "server/frame_keeper.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

}  // namespace

StatusOr<KeptRun> FrameKeeper::ReadRun(const std::string& map, const std::string& run,
                                       std::vector<FrameRecord>* frames,
                                       std::string* record) const {
  const fs::path map_dir = fs::path(options_.dir) / map;
  const std::string path = (map_dir / (run + kRunRecordSuffix)).string();
  StatusOr<std::string> text = ReadFileBytes(path);
  if (!text.ok()) {
    if (text.status().code() == StatusCode::kNotFound) {
      return NotFound("no kept run '" + run + "' of map '" + map + "'");
    }
    return text.status();
  }
  if (record != nullptr) *record = *text;
  KeptRun out;
  out.map = map;
  out.run = run;
  try {
    const YAML::Node root = YAML::Load(*text);
    out.session = root["session"].as<std::string>("");
    out.client = root["client"].as<std::string>("");
    out.started_utc = root["started_utc"].as<std::string>("");
    out.map_checksum = root["map_checksum"].as<uint32_t>(0);
    if (const YAML::Node anchor = root["anchor"]) {
      out.anchor_place = anchor["place"].as<int>(-1);
      out.anchor_name = anchor["name"].as<std::string>("");
      out.anchor_probability = anchor["probability"].as<double>(0);
      out.anchor_utc = anchor["utc"].as<std::string>("");
    }
    for (const YAML::Node& f : root["frames"]) {
      FrameRecord r;
      r.file = f["file"].as<std::string>();
      r.utc = f["utc"].as<std::string>("");
      if (!IsValidRunName(r.file)) return DataLoss(path + ": a frame file name is malformed");
      if (frames != nullptr) frames->push_back(r);
      ++out.frames;
      out.last_utc = r.utc;
    }
  } catch (const YAML::Exception& e) {
    return DataLoss("kept run record '" + path + "' cannot be read: " + e.what());
  }
  std::error_code ec;
  out.bytes = static_cast<int64_t>(fs::file_size(path, ec));
  for (auto it = fs::directory_iterator(map_dir / run, ec); !ec && it != fs::end(it);
       it.increment(ec)) {
    out.bytes += static_cast<int64_t>(it->file_size(ec));
  }
  return out;
}

StatusOr<std::vector<KeptRun>> FrameKeeper::List(const std::string& map) const {
  if (!map.empty() && !IsValidMapName(map)) {
    return InvalidArgument("'" + map + "' is not a map name (a plain file stem)");
  }
  MutexLock io(&io_mutex_);
  std::vector<std::string> maps;
  std::error_code ec;
  if (!map.empty()) {
    maps.push_back(map);
  } else {
    for (auto it = fs::directory_iterator(options_.dir, ec); !ec && it != fs::end(it);
         it.increment(ec)) {
      if (it->is_directory(ec) && IsValidMapName(it->path().filename().string())) {
        maps.push_back(it->path().filename().string());
      }
    }
    std::sort(maps.begin(), maps.end());
  }
  std::vector<KeptRun> runs;
  for (const std::string& m : maps) {
    std::vector<std::string> names;
    for (auto it = fs::directory_iterator(fs::path(options_.dir) / m, ec); !ec && it != fs::end(it);
         it.increment(ec)) {
      const std::string file = it->path().filename().string();
      const size_t n = file.size() - std::min(file.size(), sizeof(kRunRecordSuffix) - 1);
      if (file.compare(n, std::string::npos, kRunRecordSuffix) == 0 &&
          IsValidRunName(file.substr(0, n))) {
        names.push_back(file.substr(0, n));
      }
    }
    ec.clear();
    std::sort(names.begin(), names.end());
    for (const std::string& name : names) {
      StatusOr<KeptRun> run = ReadRun(m, name, nullptr);
      if (!run.ok()) {
        spdlog::warn("keep_frames: {}", run.status().message());
        continue;
      }
      runs.push_back(std::move(run).value());
    }
  }
  if (!map.empty() && runs.empty()) return NotFound("no kept frames of map '" + map + "'");
  return runs;
}

StatusOr<KeptPage> FrameKeeper::Fetch(const std::string& map, const std::string& run,
                                      int first_frame, int64_t max_bytes) const {
  if (!IsValidMapName(map)) {
    return InvalidArgument("'" + map + "' is not a map name (a plain file stem)");
  }
  if (!IsValidRunName(run)) return InvalidArgument("'" + run + "' is not a kept run's name");
  MutexLock io(&io_mutex_);
  std::vector<FrameRecord> records;
  KeptPage page;
  SCENELOC_ASSIGN_OR_RETURN(page.run, ReadRun(map, run, &records, &page.record));
  if (first_frame < 0 || first_frame > page.run.frames) {
    return InvalidArgument("run '" + run + "' has " + std::to_string(page.run.frames) +
                           " frames; first_frame " + std::to_string(first_frame) + " is past them");
  }
  int64_t bytes = 0;
  int i = first_frame;
  for (; i < page.run.frames; ++i) {
    const fs::path file = fs::path(options_.dir) / map / run / records[i].file;
    SCENELOC_ASSIGN_OR_RETURN(std::string jpeg, ReadFileBytes(file.string()));
    if (!page.frames.empty() && bytes + static_cast<int64_t>(jpeg.size()) > max_bytes) break;
    bytes += static_cast<int64_t>(jpeg.size());
    page.frames.push_back({i, records[i].file, records[i].utc, std::move(jpeg)});
  }
  page.next_frame = i;
  return page;
}

StatusOr<KeptRun> FrameKeeper::Delete(const std::string& map, const std::string& run) {
  if (!IsValidMapName(map)) {
    return InvalidArgument("'" + map + "' is not a map name (a plain file stem)");
  }
  if (!IsValidRunName(run)) return InvalidArgument("'" + run + "' is not a kept run's name");
  {
    // Writes of the run still queued are dropped, and a session still writing it moves on.
    MutexLock lock(&mutex_);
    for (auto it = queue_.begin(); it != queue_.end();) {
      if (it->map == map && it->run == run) {
        pending_bytes_ -= static_cast<int64_t>(it->jpeg.size());
        Release(it->reserved);
        it = queue_.erase(it);
      } else {
        ++it;
      }
    }
    for (auto& [key, t] : trackers_) {
      if (t.info.map == map && t.run == run) {
        t.run.clear();
        t.records.clear();
        t.record_bytes = 0;
      }
    }
  }
  MutexLock io(&io_mutex_);
  const fs::path map_dir = fs::path(options_.dir) / map;
  const fs::path record = map_dir / (run + kRunRecordSuffix);
  StatusOr<KeptRun> read = ReadRun(map, run, nullptr);
  if (read.status().code() == StatusCode::kNotFound) return read.status();
  KeptRun gone;
  if (read.ok()) {
    gone = *std::move(read);
  } else {  // a damaged record: the run goes all the same
    gone.map = map;
    gone.run = run;
  }
  std::error_code ec;
  int64_t freed = static_cast<int64_t>(fs::file_size(record, ec));
  for (auto it = fs::directory_iterator(map_dir / run, ec); !ec && it != fs::end(it);
       it.increment(ec)) {
    freed += static_cast<int64_t>(it->file_size(ec));
  }
  ec.clear();
  fs::remove_all(map_dir / run, ec);
  if (!ec) fs::remove(record, ec);
  if (ec) return OsError("cannot remove kept run", (map_dir / run).string(), ec.value());
  Release(freed);
  spdlog::info("keep_frames: deleted run {} of map '{}' ({:.1f} MB)", run, map, freed / 1e6);
  return gone;
}

}  // namespace sceneloc
