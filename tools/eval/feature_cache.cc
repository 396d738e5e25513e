#include "tools/eval/feature_cache.h"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <sstream>

#include "common/map/crc32.h"
#include "common/training/trainer.h"
#include "common/util/image_folder.h"

namespace sceneloc {
namespace {

// 4: context descriptors read one octave up (3 was a variant of it).
// 5: the entry holds its whole key and ends with a CRC-32 of everything before it.
constexpr uint32_t kCacheVersion = 5;

// Identifies a cache entry: the options, the frame, and every file (path, size and
// modification time, so an image replaced by another of the same size is a miss). Fields
// are separated, so no two different listings give the same text.
std::string CacheKey(const std::vector<std::string>& paths, const ExtractorOptions& o,
                     const ExtractionTarget* frame) {
  std::ostringstream key;
  key << "sceneloc features " << kCacheVersion << ' ' << o.max_features << ' ' << o.working_size
      << ' ' << o.context_scale << ' ' << o.contrast_threshold << ' ' << o.edge_threshold << ' '
      << o.sigma << ' ' << o.octave_layers << ' ' << o.holistic.cols << ' '
      << o.holistic.cell_pixels << ' ' << o.holistic.bins << ' ' << o.clahe_clip << ' '
      << o.root_sift;
  if (frame != nullptr) {
    key << " query " << frame->width << ' ' << frame->holistic.cols << ' ' << frame->holistic.rows
        << ' ' << frame->holistic.bins;
  }
  for (const auto& p : paths) {
    std::error_code ec;
    const auto size = std::filesystem::file_size(p, ec);
    const auto mtime = std::filesystem::last_write_time(p, ec).time_since_epoch().count();
    key << '\n' << std::filesystem::absolute(p).string() << '\t' << size << '\t' << mtime;
  }
  return key.str();
}

// The entry's file name: a hash of the key (the entry holds the key itself, so a collision
// is a miss, never the wrong features).
std::string EntryName(const std::string& key) {
  std::ostringstream name;
  name << std::hex << std::hash<std::string>{}(key) << ".features";
  return name.str();
}

template <typename T>
void Put(std::string* out, const T& v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof(T));
}
void PutBytes(std::string* out, const void* data, size_t bytes) {
  out->append(static_cast<const char*>(data), bytes);
}

// Reads from a byte buffer; every read is bounds-checked and a failed one stays failed.
// (The map file's PayloadReader is internal to map_io; this cache is the eval tools' own.)
class Reader {
 public:
  Reader(const char* data, size_t size) : data_(data), size_(size) {}
  bool Bytes(void* out, size_t n) {
    if (!ok_ || n > size_ - pos_) return ok_ = false;
    std::memcpy(out, data_ + pos_, n);
    pos_ += n;
    return true;
  }
  template <typename T>
  bool Get(T* v) {
    return Bytes(v, sizeof(T));
  }
  bool AtEnd() const { return ok_ && pos_ == size_; }

 private:
  const char* data_;
  size_t size_;
  size_t pos_ = 0;
  bool ok_ = true;
};

std::string Serialise(const std::string& key, const std::vector<FeatureSet>& sets) {
  std::string out;
  Put(&out, kCacheVersion);
  Put(&out, static_cast<uint64_t>(key.size()));
  out += key;
  Put(&out, static_cast<uint64_t>(sets.size()));
  for (const FeatureSet& f : sets) {
    Put(&out, f.image_width);
    Put(&out, f.image_height);
    Put(&out, static_cast<uint64_t>(f.keypoints.size()));
    PutBytes(&out, f.keypoints.data(), f.keypoints.size() * sizeof(Keypoint));
    PutBytes(&out, f.local.data(), static_cast<size_t>(f.local.size()) * sizeof(float));
    PutBytes(&out, f.context.data(), static_cast<size_t>(f.context.size()) * sizeof(float));
    Put(&out, f.holistic_grid);
    PutBytes(&out, f.holistic.data(), f.holistic.size() * sizeof(float));
  }
  Put(&out, Crc32(out.data(), out.size()));
  return out;
}

// Writes the entry through a temporary file renamed into place, so a reader never sees half
// an entry; on any failure the cache is left without it (and without the temporary file).
void Write(const std::string& path, const std::string& bytes) {
  const std::string tmp = path + ".tmp";
  bool written = false;
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    written = static_cast<bool>(out);
  }
  std::error_code ec;
  if (written) std::filesystem::rename(tmp, path, ec);
  if (!written || ec) std::filesystem::remove(tmp, ec);
}

bool ParseSets(Reader* in, size_t expected, std::vector<FeatureSet>* sets) {
  uint64_t count = 0;
  if (!in->Get(&count) || count != expected) return false;
  sets->resize(count);
  for (FeatureSet& f : *sets) {
    uint64_t n = 0;
    if (!in->Get(&f.image_width) || !in->Get(&f.image_height) || !in->Get(&n) || n > 1000000) {
      return false;
    }
    f.keypoints.resize(n);
    f.local.resize(static_cast<Eigen::Index>(n), kDescriptorSize);
    f.context.resize(static_cast<Eigen::Index>(n), kDescriptorSize);
    if (!in->Bytes(f.keypoints.data(), n * sizeof(Keypoint)) ||
        !in->Bytes(f.local.data(), static_cast<size_t>(f.local.size()) * sizeof(float)) ||
        !in->Bytes(f.context.data(), static_cast<size_t>(f.context.size()) * sizeof(float)) ||
        !in->Get(&f.holistic_grid) || f.holistic_grid.size() < 0 ||
        f.holistic_grid.size() > 1000000) {
      return false;
    }
    f.holistic.resize(static_cast<size_t>(f.holistic_grid.size()));
    if (!in->Bytes(f.holistic.data(), f.holistic.size() * sizeof(float))) return false;
  }
  return true;
}

// Reads the entry at `path` if it is whole (its CRC matches), of this version, made for
// exactly `key`, and holds `expected` feature sets with nothing after them.
bool Read(const std::string& path, const std::string& key, size_t expected,
          std::vector<FeatureSet>* sets) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return false;
  std::ifstream file(path, std::ios::binary);
  if (!file) return false;
  const std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  uint32_t crc = 0;
  if (bytes.size() < sizeof(crc)) return false;
  const size_t body = bytes.size() - sizeof(crc);
  std::memcpy(&crc, bytes.data() + body, sizeof(crc));
  if (crc != Crc32(bytes.data(), body)) return false;
  Reader in(bytes.data(), body);  // the CRC after the body is not part of it
  uint32_t version = 0;
  uint64_t key_size = 0;
  if (!in.Get(&version) || version != kCacheVersion || !in.Get(&key_size) ||
      key_size != key.size()) {
    return false;
  }
  std::string stored(key.size(), '\0');
  if (!in.Bytes(stored.data(), stored.size()) || stored != key) return false;
  return ParseSets(&in, expected, sets) && in.AtEnd();
}

}  // namespace

StatusOr<std::vector<FeatureSet>> ExtractCached(const std::vector<std::string>& paths,
                                                const ExtractorOptions& options,
                                                const std::string& cache_dir, int threads,
                                                const ExtractionTarget* map_frame) {
  std::string key, entry;
  if (!cache_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(cache_dir, ec);
    key = CacheKey(paths, options, map_frame);
    entry = cache_dir + "/" + EntryName(key);
    std::vector<FeatureSet> cached;
    if (Read(entry, key, paths.size(), &cached)) return cached;
  }
  std::vector<FeatureSet> sets;
  if (map_frame == nullptr) {
    SCENELOC_ASSIGN_OR_RETURN(sets, ExtractFolder(paths, options, threads, nullptr));
  } else {
    const auto target = [&](int width, int height) {
      return QueryTarget(width, height, map_frame->width, map_frame->holistic);
    };
    SCENELOC_ASSIGN_OR_RETURN(sets, ExtractImages(paths, options, target, threads, nullptr));
  }
  if (!entry.empty()) Write(entry, Serialise(key, sets));
  return sets;
}

StatusOr<std::vector<FeatureSet>> ExtractFolderCached(const std::string& dir,
                                                      const ExtractorOptions& options,
                                                      const std::string& cache_dir, int threads,
                                                      std::vector<std::string>* names,
                                                      const ExtractionTarget* map_frame) {
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<std::string> paths, ListImageFiles(dir));
  names->clear();
  for (const auto& p : paths) names->push_back(FileName(p));
  return ExtractCached(paths, options, cache_dir, threads, map_frame);
}

}  // namespace sceneloc
