#include "tools/eval/feature_cache.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include "common/training/trainer.h"
#include "common/util/image_folder.h"

namespace sceneloc {
namespace {

// 4: context descriptors read one octave up (issue 10; 3 was a variant of it).
constexpr uint32_t kCacheVersion = 4;

// Identifies a cache entry: the folder, its files (names and sizes) and the options.
std::string CacheKey(const std::vector<std::string>& paths, const ExtractorOptions& o,
                     const ExtractionTarget* frame) {
  std::ostringstream key;
  key << kCacheVersion << ' ' << o.max_features << ' ' << o.working_size << ' ' << o.context_scale
      << ' ' << o.contrast_threshold << ' ' << o.edge_threshold << ' ' << o.sigma << ' '
      << o.octave_layers << ' ' << o.holistic.cols << ' ' << o.holistic.cell_pixels << ' '
      << o.holistic.bins << ' ' << o.clahe_clip << ' ' << o.root_sift;
  if (frame != nullptr) {
    key << " query " << frame->width << ' ' << frame->holistic.cols << ' ' << frame->holistic.rows
        << ' ' << frame->holistic.bins;
  }
  std::error_code ec;
  for (const auto& p : paths) {
    key << std::filesystem::absolute(p).string() << std::filesystem::file_size(p, ec);
  }
  std::ostringstream name;
  name << std::hex << std::hash<std::string>{}(key.str()) << ".features";
  return name.str();
}

template <typename T>
void Put(std::ofstream& out, const T& v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof(T));
}
template <typename T>
bool Get(std::ifstream& in, T* v) {
  return static_cast<bool>(in.read(reinterpret_cast<char*>(v), sizeof(T)));
}

void Write(const std::string& path, const std::vector<FeatureSet>& sets) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    Put(out, kCacheVersion);
    Put(out, static_cast<uint64_t>(sets.size()));
    for (const FeatureSet& f : sets) {
      Put(out, f.image_width);
      Put(out, f.image_height);
      Put(out, static_cast<uint64_t>(f.keypoints.size()));
      out.write(reinterpret_cast<const char*>(f.keypoints.data()),
                static_cast<std::streamsize>(f.keypoints.size() * sizeof(Keypoint)));
      out.write(reinterpret_cast<const char*>(f.local.data()),
                static_cast<std::streamsize>(f.local.size() * sizeof(float)));
      out.write(reinterpret_cast<const char*>(f.context.data()),
                static_cast<std::streamsize>(f.context.size() * sizeof(float)));
      Put(out, f.holistic_grid);
      out.write(reinterpret_cast<const char*>(f.holistic.data()),
                static_cast<std::streamsize>(f.holistic.size() * sizeof(float)));
    }
    if (!out) return;
  }
  std::filesystem::rename(tmp, path);
}

bool Read(const std::string& path, size_t expected, std::vector<FeatureSet>* sets) {
  std::ifstream in(path, std::ios::binary);
  uint32_t version = 0;
  uint64_t count = 0;
  if (!Get(in, &version) || version != kCacheVersion || !Get(in, &count) || count != expected) {
    return false;
  }
  sets->resize(count);
  for (FeatureSet& f : *sets) {
    uint64_t n = 0;
    if (!Get(in, &f.image_width) || !Get(in, &f.image_height) || !Get(in, &n) || n > 1000000) {
      return false;
    }
    f.keypoints.resize(n);
    f.local.resize(static_cast<Eigen::Index>(n), kDescriptorSize);
    f.context.resize(static_cast<Eigen::Index>(n), kDescriptorSize);
    in.read(reinterpret_cast<char*>(f.keypoints.data()),
            static_cast<std::streamsize>(n * sizeof(Keypoint)));
    in.read(reinterpret_cast<char*>(f.local.data()),
            static_cast<std::streamsize>(f.local.size() * sizeof(float)));
    in.read(reinterpret_cast<char*>(f.context.data()),
            static_cast<std::streamsize>(f.context.size() * sizeof(float)));
    if (!Get(in, &f.holistic_grid) || f.holistic_grid.size() < 0 ||
        f.holistic_grid.size() > 1000000) {
      return false;
    }
    f.holistic.resize(static_cast<size_t>(f.holistic_grid.size()));
    in.read(reinterpret_cast<char*>(f.holistic.data()),
            static_cast<std::streamsize>(f.holistic.size() * sizeof(float)));
    if (!in) return false;
  }
  return true;
}

}  // namespace

StatusOr<std::vector<FeatureSet>> ExtractCached(const std::vector<std::string>& paths,
                                                const ExtractorOptions& options,
                                                const std::string& cache_dir, int threads,
                                                const ExtractionTarget* map_frame) {
  std::string entry;
  if (!cache_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(cache_dir, ec);
    entry = cache_dir + "/" + CacheKey(paths, options, map_frame);
    std::vector<FeatureSet> cached;
    if (Read(entry, paths.size(), &cached)) return cached;
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
  if (!entry.empty()) Write(entry, sets);
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
