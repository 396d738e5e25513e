#include "server/map_registry.h"

#include <algorithm>
#include <filesystem>
#include <new>

#include "common/map/map_io.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

// The self-test query of one location uses at most this many landmarks (enough to
// exercise every stage; more only costs load time).
constexpr int kSelfTestMaxFeatures = 1500;

void CopyUnitRow(const DescriptorMatrix& from, int row, DescriptorMatrix* to, int to_row) {
  to->row(to_row) = from.row(row);
  const float norm = to->row(to_row).norm();
  if (norm > 0) to->row(to_row) /= norm;
}

}  // namespace

FeatureSet SelfTestFeatures(const Map& map, int location) {
  const uint32_t begin = map.image_offsets[static_cast<size_t>(location)];
  const uint32_t end = map.image_offsets[static_cast<size_t>(location) + 1];
  const int n = std::min(static_cast<int>(end - begin), kSelfTestMaxFeatures);
  FeatureSet f;
  f.image_width = map.image_width;
  f.image_height = map.image_height;
  f.keypoints.resize(static_cast<size_t>(n));
  f.local.resize(n, kDescriptorSize);
  f.context.resize(n, kDescriptorSize);
  for (int i = 0; i < n; ++i) {
    const uint32_t g = map.image_landmarks[begin + static_cast<uint32_t>(i)];
    Keypoint& k = f.keypoints[static_cast<size_t>(i)];
    k.x = map.mean_x[g];
    k.y = map.mean_y[g];
    k.size = 8.0f;
    // Where and how large g was seen in this very image (G_l holds only landmarks seen in
    // l), so verification's epipolar and scale checks see the location as it was.
    for (uint32_t o = map.observation_offsets[g]; o < map.observation_offsets[g + 1]; ++o) {
      if (map.observation_image[o] == static_cast<uint32_t>(location)) {
        k.x = map.observation_x[o];
        k.y = map.observation_y[o];
        k.size = map.observation_size[o];
        break;
      }
    }
    k.response = 1.0f;
    CopyUnitRow(map.local_mean, static_cast<int>(g), &f.local, i);
    CopyUnitRow(map.context_mean, static_cast<int>(g), &f.context, i);
  }
  return f;
}

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
  const int images = map.num_images();
  const int probes = std::min(options_.self_test_locations, images);
  for (int p = 0; p < probes; ++p) {
    // Spread the probes over the tour: first, last, and evenly between.
    const int location = probes == 1 ? images / 2 : p * (images - 1) / (probes - 1);
    auto result = Localise(SelfTestFeatures(map, location), map, options_.self_test, nullptr);
    if (!result.ok()) {
      return FailedPrecondition("self-test query of location " + std::to_string(location) +
                                " failed: " + result.status().message());
    }
    const auto& ranked = result->ranked;
    const bool found = std::any_of(ranked.begin(), ranked.end(),
                                   [&](const RankedLocation& r) { return r.index == location; });
    if (!found) {
      return FailedPrecondition(
          "self-test: location " + std::to_string(location) +
          "'s own landmarks do not rank it among the best " + std::to_string(ranked.size()) +
          (ranked.empty() ? "" : " (best: " + std::to_string(ranked[0].index) + ")"));
    }
  }
  return Status::Ok();
}

Status MapRegistry::CountFailure(Status status) {
  MutexLock lock(&mutex_);
  ++load_failures_;
  return status;
}

StatusOr<std::shared_ptr<const LoadedMap>> MapRegistry::Load(const std::string& path) {
  MutexLock load_lock(&load_mutex_);
  const std::string name = fs::path(path).stem().string();
  if (name.empty() || name[0] == '.') {
    return CountFailure(InvalidArgument("'" + path + "' does not name a map (no file stem)"));
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
    if (it->path().extension() == kMapFileExtension && it->is_regular_file(ec)) {
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
