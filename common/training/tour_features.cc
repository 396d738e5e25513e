#include "common/training/tour_features.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <type_traits>

namespace sceneloc {
namespace {

static_assert(std::is_trivially_copyable_v<Keypoint> && std::is_trivially_copyable_v<HolisticGrid>);

// What precedes an image's arrays in the spool.
struct RecordHeader {
  int32_t width = 0;
  int32_t height = 0;
  uint32_t count = 0;  // keypoints
  HolisticGrid holistic_grid;
  uint32_t holistic_values = 0;
};

std::string ErrnoText() { return std::strerror(errno); }

// Writes all `n` bytes at `offset`, retrying short writes.
bool WriteAll(int fd, const void* data, size_t n, uint64_t offset) {
  const char* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = pwrite(fd, p, n, static_cast<off_t>(offset));
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= static_cast<size_t>(w);
    offset += static_cast<uint64_t>(w);
  }
  return true;
}

bool ReadAll(int fd, void* data, size_t n, uint64_t offset) {
  char* p = static_cast<char*>(data);
  while (n > 0) {
    const ssize_t r = pread(fd, p, n, static_cast<off_t>(offset));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return false;
    p += r;
    n -= static_cast<size_t>(r);
    offset += static_cast<uint64_t>(r);
  }
  return true;
}

// An unnamed file in `dir`: O_TMPFILE where the file system has it, else a named one
// unlinked at once.
int OpenUnnamed(const std::string& dir) {
#ifdef O_TMPFILE
  const int fd = open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd >= 0) return fd;
#endif
  std::string path = dir + "/.sceneloc-features-XXXXXX";
  const int named = mkostemp(path.data(), O_CLOEXEC);
  if (named >= 0) unlink(path.c_str());
  return named;
}

// memcpy and string::append with an empty source: an empty vector's or matrix's data() may
// be null, which memcpy must never be given, even for zero bytes.
void AppendBytes(std::string* record, const void* p, size_t n) {
  if (n > 0) record->append(static_cast<const char*>(p), n);
}

const char* TakeBytes(const char* p, void* out, size_t n) {
  if (n > 0) std::memcpy(out, p, n);
  return p + n;
}

}  // namespace

TourWindow WholeTour(const std::vector<FeatureSet>& tour) {
  return TourWindow(0, tour.data(), tour.size());
}

StatusOr<TourWindow> TourInMemory::Window(size_t begin, size_t end) const {
  return TourWindow(begin, tour_.data() + begin, end - begin);
}

StatusOr<std::unique_ptr<FeatureSpool>> FeatureSpool::Create(const std::string& dir) {
  const int fd = OpenUnnamed(dir);
  if (fd < 0) {
    return IoError("cannot make a feature spool in '" + dir + "': " + ErrnoText());
  }
  return std::unique_ptr<FeatureSpool>(new FeatureSpool(fd, dir));
}

FeatureSpool::~FeatureSpool() { close(fd_); }

size_t FeatureSpool::size() const { return offsets_.size() - 1; }

uint64_t FeatureSpool::bytes() const { return offsets_.back(); }

Status FeatureSpool::Append(const FeatureSet& f) {
  RecordHeader header;
  header.width = f.image_width;
  header.height = f.image_height;
  header.count = static_cast<uint32_t>(f.keypoints.size());
  header.holistic_grid = f.holistic_grid;
  header.holistic_values = static_cast<uint32_t>(f.holistic.size());
  const size_t descriptor_bytes = static_cast<size_t>(f.local.size()) * sizeof(float);
  std::string record;
  record.reserve(sizeof(header) + header.count * sizeof(Keypoint) + 2 * descriptor_bytes +
                 f.holistic.size() * sizeof(float));
  record.append(reinterpret_cast<const char*>(&header), sizeof(header));
  AppendBytes(&record, f.keypoints.data(), f.keypoints.size() * sizeof(Keypoint));
  AppendBytes(&record, f.local.data(), descriptor_bytes);
  AppendBytes(&record, f.context.data(), static_cast<size_t>(f.context.size()) * sizeof(float));
  AppendBytes(&record, f.holistic.data(), f.holistic.size() * sizeof(float));
  const uint64_t at = offsets_.back();
  if (!WriteAll(fd_, record.data(), record.size(), at)) {
    return IoError("cannot write the feature spool in '" + dir_ + "' (image " +
                   std::to_string(size()) + ", " + std::to_string(at >> 20) +
                   " MiB written): " + ErrnoText());
  }
  offsets_.push_back(at + record.size());
  return Status::Ok();
}

StatusOr<FeatureSet> FeatureSpool::Read(size_t image) const {
  const uint64_t at = offsets_[image];
  std::string record(offsets_[image + 1] - at, '\0');
  if (!ReadAll(fd_, record.data(), record.size(), at)) {
    return IoError("cannot read image " + std::to_string(image) +
                   " back from the feature spool in '" + dir_ + "': " + ErrnoText());
  }
  RecordHeader header;
  std::memcpy(&header, record.data(), sizeof(header));
  FeatureSet f;
  f.image_width = header.width;
  f.image_height = header.height;
  f.holistic_grid = header.holistic_grid;
  const char* p = record.data() + sizeof(header);
  f.keypoints.resize(header.count);
  p = TakeBytes(p, f.keypoints.data(), header.count * sizeof(Keypoint));
  f.local.resize(header.count, kDescriptorSize);
  f.context.resize(header.count, kDescriptorSize);
  const size_t descriptor_bytes =
      static_cast<size_t>(header.count) * kDescriptorSize * sizeof(float);
  p = TakeBytes(p, f.local.data(), descriptor_bytes);
  p = TakeBytes(p, f.context.data(), descriptor_bytes);
  f.holistic.resize(header.holistic_values);
  TakeBytes(p, f.holistic.data(), header.holistic_values * sizeof(float));
  return f;
}

StatusOr<TourWindow> FeatureSpool::Window(size_t begin, size_t end) const {
  std::vector<FeatureSet> sets;
  sets.reserve(end - begin);
  for (size_t i = begin; i < end; ++i) {
    SCENELOC_ASSIGN_OR_RETURN(FeatureSet f, Read(i));
    sets.push_back(std::move(f));
  }
  return TourWindow(begin, std::move(sets));
}

}  // namespace sceneloc
