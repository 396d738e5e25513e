#include "server/map_registry.h"

#include <algorithm>
#include <filesystem>
#include <new>

#include "common/map/map_io.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

}  // namespace

MapRegistry::MapRegistry(const Options& options) : options_(options) {}

std::shared_ptr<const LoadedMap> MapRegistry::Get(const std::string& name) const {
  MutexLock lock(&mutex_);
  const auto it = maps_.find(name);
  return it == maps_.end() ? nullptr : it->second;
}

std::vector<std::shared_ptr<const LoadedMap>> MapRegistry::List() const {
  MutexLock lock(&mutex_);
  std::vector<std::shared_ptr<const LoadedMap>> out;
  for (const auto& entry : maps_) out.push_back(entry.second);
  return out;
}

Status MapRegistry::SelfTest(const Map& map) const {
  return SelfTestMap(map, options_.self_test, options_.self_test_locations);
}

Status MapRegistry::CountFailure(Status status) {
  MutexLock lock(&mutex_);
  ++load_failures_;
  return status;
}

StatusOr<std::shared_ptr<const LoadedMap>> MapRegistry::Load(const std::string& path) {
  MutexLock load_lock(&load_mutex_);
  const std::string name = fs::path(path).stem().string();
  if (const std::string problem = MapNameProblem(name); !problem.empty()) {
    return CountFailure(InvalidArgument("'" + path + "' cannot be served: " + problem));
  }
  MapFileInfo info;
  StatusOr<Map> map = Internal("not loaded");
  Status tested;
  // A load must never take the loader thread (and the process) down, whatever the file.
  try {
    map = LoadMap(path, &info, options_.load);
    if (map.ok()) tested = SelfTest(*map);
  } catch (const std::bad_alloc&) {
    return CountFailure(
        ResourceExhausted("map file '" + path + "': out of memory while loading it"));
  } catch (const std::exception& e) {
    return CountFailure(Internal("map file '" + path + "': unexpected exception: " + e.what()));
  }
  if (!map.ok()) return CountFailure(map.status());
  if (!tested.ok()) return CountFailure(FailedPrecondition(path + ": " + tested.message()));

  auto loaded = std::make_shared<LoadedMap>();
  loaded->name = name;
  loaded->path = path;
  loaded->checksum = info.checksum;
  loaded->loaded_at = std::chrono::system_clock::now();
  loaded->map = std::move(map).value();
  loaded->places_key = loaded->map.PlacesKey();
  loaded->extractor = FeatureExtractor::Create(loaded->map.options.extractor);
  loaded->sequence =
      std::make_unique<const SequenceFilter>(loaded->map, options_.self_test.sequence);

  MutexLock lock(&mutex_);
  loaded->generation = ++generations_[name];
  ++loads_;
  std::shared_ptr<const LoadedMap> snapshot = std::move(loaded);
  maps_[name] = snapshot;
  return snapshot;
}

bool MapRegistry::Remove(const std::string& name) {
  MutexLock load_lock(&load_mutex_);
  std::shared_ptr<const LoadedMap> dropped;  // freed after the lock, if no request holds it
  MutexLock lock(&mutex_);
  const auto it = maps_.find(name);
  if (it == maps_.end()) return false;
  dropped = std::move(it->second);
  maps_.erase(it);
  ++unloads_;
  return true;
}

Status MapRegistry::LoadDirectory(const std::string& dir, std::vector<Status>* failures,
                                  std::vector<std::string>* ignored) {
  std::error_code ec;
  std::vector<std::string> paths;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string file = it->path().filename().string();
    if (!MapNameOfFile(file).empty() && it->is_regular_file(ec)) {
      paths.push_back(it->path().string());
    } else if (ignored != nullptr && !file.empty() && file[0] != '.' &&
               file.find(std::string(kMapFileExtension) + ".tmp.") == std::string::npos) {
      ignored->push_back(file);
    }
  }
  if (ignored != nullptr) std::sort(ignored->begin(), ignored->end());
  if (ec) return IoError("maps directory '" + dir + "' cannot be listed: " + ec.message());
  std::sort(paths.begin(), paths.end());
  for (const std::string& path : paths) {
    auto loaded = Load(path);
    if (!loaded.ok() && failures != nullptr) failures->push_back(loaded.status());
  }
  return Status::Ok();
}

uint64_t MapRegistry::loads() const {
  MutexLock lock(&mutex_);
  return loads_;
}

uint64_t MapRegistry::load_failures() const {
  MutexLock lock(&mutex_);
  return load_failures_;
}

uint64_t MapRegistry::unloads() const {
  MutexLock lock(&mutex_);
  return unloads_;
}

}  // namespace sceneloc
