#include "common/map/map_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>
#include <type_traits>
#include <vector>

#include "common/map/crc32.h"

// Arrays are copied between memory and the file with memcpy, which is only the
// little-endian IEEE layout the format specifies on a little-endian IEEE host.
#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "map_io.cc copies arrays with memcpy and needs a little-endian host"
#endif

namespace sceneloc {
namespace {

static_assert(std::numeric_limits<float>::is_iec559 && std::numeric_limits<double>::is_iec559);
static_assert(sizeof(int) == 4, "the format stores int fields as i32");
static_assert(std::is_trivially_copyable_v<Neighbour> && sizeof(Neighbour) == 32 &&
                  offsetof(Neighbour, cooccurrence) == 4 && offsetof(Neighbour, angle_dmax) == 28,
              "Neighbour is copied as the 32-byte record of map_io.h");
// A new option must be stored too: add it to TransferOptions, to the layout in
// map_io.h and to the round-trip test, bump kMapFormatVersion, then update these sizes.
static_assert(sizeof(void*) != 8 || sizeof(ExtractorOptions) == 80,
              "ExtractorOptions changed: update the map file format");
static_assert(sizeof(void*) != 8 || sizeof(TrainOptions) == 216,
              "TrainOptions changed: update the map file format");

template <typename T>
using IfArithmetic = std::enable_if_t<std::is_arithmetic_v<T>, int>;
template <typename T>
using IfPod = std::enable_if_t<std::is_trivially_copyable_v<T>, int>;

// Appends fields to a byte string in the file's layout. Field names are unused here;
// they let one TransferMap() describe the layout for both writing and reading.
class PayloadWriter {
 public:
  explicit PayloadWriter(std::string* out) : out_(out) {}

  template <typename T, IfArithmetic<T> = 0>
  void Field(const char* /*name*/, const T& value) {
    Append(&value, sizeof(T));
  }
  void Field(const char* name, const bool& value) { Field(name, uint8_t{value}); }
  void Field(const char* name, const std::string& value) {
    Field(name, uint64_t{value.size()});
    Append(value.data(), value.size());
  }
  void Field(const char* name, const std::vector<std::string>& values) {
    Field(name, uint64_t{values.size()});
    for (const std::string& value : values) Field(name, value);
  }
  template <typename T, IfPod<T> = 0>
  void Field(const char* name, const std::vector<T>& values) {
    Field(name, uint64_t{values.size()});
    Append(values.data(), values.size() * sizeof(T));
  }
  template <typename Derived>
  void Field(const char* name, const Eigen::PlainObjectBase<Derived>& m) {
    static_assert(Derived::IsRowMajor || Derived::ColsAtCompileTime == 1);
    Field(name, static_cast<uint64_t>(m.rows()));
    Field(name, static_cast<uint64_t>(m.cols()));
    Append(m.data(), static_cast<size_t>(m.size()) * sizeof(typename Derived::Scalar));
  }

 private:
  void Append(const void* data, size_t n) { out_->append(static_cast<const char*>(data), n); }

  std::string* out_;
};

// Reads fields in the file's layout from a bounds-checked buffer. The first failure
// sticks: later fields are left untouched and status() reports the first problem. A
// count is checked against the bytes left before anything is allocated for it.
// Where a PayloadReader's bytes come from: memory, or a file read as it is parsed (so a
// map is never held twice, and a file that shrinks under the reader is a read error, not
// a SIGBUS as it would be with mmap).
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  // Copies the next n bytes to `out`; an error when they cannot all be had.
  virtual Status Read(void* out, size_t n) = 0;
};

class MemorySource : public ByteSource {
 public:
  explicit MemorySource(const char* data) : data_(data) {}
  Status Read(void* out, size_t n) override {
    if (n > 0) std::memcpy(out, data_, n);
    data_ += n;
    return Status::Ok();
  }

 private:
  const char* data_;  // the caller checked that enough bytes follow
};

class PayloadReader {
 public:
  // Reads `size` payload bytes from `source`.
  PayloadReader(ByteSource* source, size_t size) : source_(source), size_(size) {}

  const Status& status() const { return status_; }
  size_t remaining() const { return size_ - pos_; }

  template <typename T, IfArithmetic<T> = 0>
  void Field(const char* name, T& value) {
    Copy(name, &value, sizeof(T));
  }
  // A u8 that must be 0 or 1.
  void Field(const char* name, bool& value) {
    uint8_t byte = 0;
    Field(name, byte);
    if (byte > 1) Fail(std::string(name) + " is " + std::to_string(byte) + ", must be 0 or 1");
    value = byte == 1;
  }
  void Field(const char* name, std::string& value) {
    uint64_t n = 0;
    Field(name, n);
    if (!Fits(name, n, 1)) return;
    value.resize(n);
    Copy(name, value.data(), n);
  }
  void Field(const char* name, std::vector<std::string>& values) {
    uint64_t n = 0;
    Field(name, n);
    if (!Fits(name, n, sizeof(uint64_t))) return;  // each string has at least its count
    values.resize(n);
    for (size_t i = 0; i < n && status_.ok(); ++i) Field(name, values[i]);
  }
  template <typename T, IfPod<T> = 0>
  void Field(const char* name, std::vector<T>& values) {
    uint64_t n = 0;
    Field(name, n);
    if (!Fits(name, n, sizeof(T))) return;
    values.resize(n);
    Copy(name, values.data(), n * sizeof(T));
  }
  template <typename Derived>
  void Field(const char* name, Eigen::PlainObjectBase<Derived>& m);

 private:
  // Whether `count` elements of `element_bytes` fit in what is left; records an error
  // if not (or if an earlier field failed). Checked before anything is allocated, so a
  // declared count can never ask for more memory than the payload holds.
  bool Fits(const char* name, uint64_t count, size_t element_bytes);
  void Copy(const char* name, void* out, size_t n);
  void Fail(const std::string& message) {
    if (status_.ok()) status_ = DataLoss(message);
  }

  ByteSource* source_;
  size_t size_;
  size_t pos_ = 0;
  Status status_;
};

template <typename Derived>
void PayloadReader::Field(const char* name, Eigen::PlainObjectBase<Derived>& m) {
  constexpr int kCols = Derived::ColsAtCompileTime;
  static_assert(kCols != Eigen::Dynamic && (Derived::IsRowMajor || kCols == 1));
  uint64_t rows = 0, cols = 0;
  Field(name, rows);
  Field(name, cols);
  if (status_.ok() && cols != kCols) {
    Fail(std::string(name) + " has " + std::to_string(cols) + " columns, expected " +
         std::to_string(kCols));
  }
  if (!Fits(name, rows, kCols * sizeof(typename Derived::Scalar))) return;
  m.resize(static_cast<Eigen::Index>(rows), kCols);
  Copy(name, m.data(), static_cast<size_t>(m.size()) * sizeof(typename Derived::Scalar));
}

bool PayloadReader::Fits(const char* name, uint64_t count, size_t element_bytes) {
  if (!status_.ok()) return false;
  if (count <= remaining() / element_bytes) return true;
  Fail(std::string(name) + " at payload offset " + std::to_string(pos_) + " declares " +
       std::to_string(count) + " elements of " + std::to_string(element_bytes) +
       " bytes but only " + std::to_string(remaining()) + " bytes are left");
  return false;
}

void PayloadReader::Copy(const char* name, void* out, size_t n) {
  if (!status_.ok()) return;
  if (n > remaining()) {
    Fail(std::string(name) + " at payload offset " + std::to_string(pos_) + " needs " +
         std::to_string(n) + " bytes but only " + std::to_string(remaining()) + " are left");
    return;
  }
  if (Status read = source_->Read(out, n); !read.ok()) {
    status_ = read;
    return;
  }
  pos_ += n;
}

// Fields of format version 1 that later versions store differently; read, then converted
// by UpgradeV1 once the map's frame is known.
struct V1Fields {
  double image_scale = 0;          // now: extractor.working_size
  double ransac_threshold_px = 0;  // now: ransac_threshold, a fraction of the frame
  double distance_var_floor = 0;   // now: distance_sd_floor, a fraction of the frame
};

// The payload layout, shared by writing (Archive = PayloadWriter, const fields) and
// reading (PayloadReader, mutable fields) of format `version`. Keep it in step with
// map_io.h. Writing always uses kMapFormatVersion.
template <typename Archive, typename Options, typename V1>
void TransferOptions(Archive& a, Options& o, uint32_t version, V1& v1) {
  const bool v2 = version >= 2;
  a.Field("extractor.max_features", o.extractor.max_features);
  if (v2) {
    a.Field("extractor.working_size", o.extractor.working_size);
  } else {
    a.Field("extractor.image_scale", v1.image_scale);
  }
  a.Field("extractor.context_scale", o.extractor.context_scale);
  a.Field("extractor.contrast_threshold", o.extractor.contrast_threshold);
  a.Field("extractor.edge_threshold", o.extractor.edge_threshold);
  a.Field("extractor.sigma", o.extractor.sigma);
  a.Field("extractor.max_image_side", o.extractor.max_image_side);
  if (v2) {
    a.Field("extractor.clahe_clip", o.extractor.clahe_clip);
    a.Field("extractor.root_sift", o.extractor.root_sift);
    a.Field("extractor.holistic_cols", o.extractor.holistic.cols);
    a.Field("extractor.holistic_cell_pixels", o.extractor.holistic.cell_pixels);
    a.Field("extractor.holistic_bins", o.extractor.holistic.bins);
    a.Field("extractor.holistic_max_shift", o.extractor.holistic.max_shift);
  }
  a.Field("track_distance_threshold", o.track_distance_threshold);
  if (v2) {
    a.Field("ransac_threshold", o.ransac_threshold);
  } else {
    a.Field("ransac_threshold_px", v1.ransac_threshold_px);
  }
  a.Field("ransac_confidence", o.ransac_confidence);
  a.Field("min_links_per_pair", o.min_links_per_pair);
  a.Field("min_track_length", o.min_track_length);
  if (v2) a.Field("min_landmarks_per_image", o.min_landmarks_per_image);
  a.Field("local_var_floor", o.local_var_floor);
  a.Field("context_var_floor", o.context_var_floor);
  if (v2) {
    a.Field("distance_sd_floor", o.distance_sd_floor);
  } else {
    a.Field("distance_var_floor", v1.distance_var_floor);
  }
  a.Field("angle_var_floor", o.angle_var_floor);
  a.Field("quality_s_min", o.quality_s_min);
  a.Field("quality_fp_prior", o.quality_fp_prior);
  a.Field("eta", o.eta);
  a.Field("q_min", o.q_min);
  a.Field("max_neighbours", o.max_neighbours);
  if (v2) {
    a.Field("tolerance", o.tolerance);
    a.Field("confidence_temperature", o.confidence_temperature);
    a.Field("map_evidence_slope", o.map_evidence_slope);
    a.Field("map_evidence_offset", o.map_evidence_offset);
  }
}

template <typename Archive, typename Provenance>
void TransferProvenance(Archive& a, Provenance& p) {
  a.Field("provenance.tour_dir", p.tour_dir);
  a.Field("provenance.created_utc", p.created_utc);
  a.Field("provenance.tool_version", p.tool_version);
  a.Field("provenance.num_features", p.num_features);
  a.Field("provenance.num_tracks", p.num_tracks);
  a.Field("provenance.num_candidates", p.num_candidates);
}

template <typename Archive, typename CalibrationT>
void TransferCalibration(Archive& a, CalibrationT& c) {
  a.Field("calibration.valid", c.valid);
  a.Field("calibration.off_map_distance", c.off_map_distance);
  a.Field("calibration.off_map_spread", c.off_map_spread);
  a.Field("calibration.samples", c.samples);
}

template <typename Archive, typename MapT, typename V1>
void TransferMap(Archive& a, MapT& m, uint32_t version, V1& v1) {
  TransferOptions(a, m.options, version, v1);
  TransferProvenance(a, m.provenance);
  if (version >= 2) TransferCalibration(a, m.calibration);
  a.Field("image_names", m.image_names);
  a.Field("image_width", m.image_width);
  a.Field("image_height", m.image_height);
  if (version >= 2) {
    a.Field("holistic_grid.cols", m.holistic_grid.cols);
    a.Field("holistic_grid.rows", m.holistic_grid.rows);
    a.Field("holistic_grid.bins", m.holistic_grid.bins);
    a.Field("holistic", m.holistic);
  }
  a.Field("local_mean", m.local_mean);
  a.Field("local_dmax", m.local_dmax);
  a.Field("local_var", m.local_var);
  a.Field("context_mean", m.context_mean);
  a.Field("context_dmax", m.context_dmax);
  a.Field("context_var", m.context_var);
  a.Field("mean_x", m.mean_x);
  a.Field("mean_y", m.mean_y);
  a.Field("quality", m.quality);
  a.Field("observation_offsets", m.observation_offsets);
  a.Field("observation_image", m.observation_image);
  a.Field("observation_x", m.observation_x);
  a.Field("observation_y", m.observation_y);
  a.Field("observation_size", m.observation_size);
  if (version >= 2) a.Field("observation_angle", m.observation_angle);
  a.Field("neighbour_offsets", m.neighbour_offsets);
  a.Field("neighbours", m.neighbours);
  a.Field("image_offsets", m.image_offsets);
  a.Field("image_landmarks", m.image_landmarks);
}

// A version-1 map in today's terms: its working frame is the frame it was made in, its
// pixel settings become fractions of that frame, and it has no holistic descriptors and
// no coverage rule. Leaves a settings error for Validate() to report.
void UpgradeV1(const V1Fields& v1, Map* map) {
  TrainOptions& o = map->options;
  const double long_side = std::max(1, map->frame_long_side());
  o.extractor.working_size = map->frame_long_side();
  o.extractor.holistic.cols = 0;
  o.ransac_threshold = v1.ransac_threshold_px / long_side;
  o.distance_sd_floor = std::sqrt(std::max(0.0, v1.distance_var_floor)) / long_side;
  o.min_landmarks_per_image = 0;
}

// --- Header ---

uint32_t GetU32(const char* p) {
  const auto* u = reinterpret_cast<const unsigned char*>(p);
  return uint32_t{u[0]} | uint32_t{u[1]} << 8 | uint32_t{u[2]} << 16 | uint32_t{u[3]} << 24;
}

uint64_t GetU64(const char* p) { return uint64_t{GetU32(p)} | uint64_t{GetU32(p + 4)} << 32; }

void PutU32(uint32_t v, char* p) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<char>((v >> (8 * i)) & 0xFFu);
}

void PutU64(uint64_t v, char* p) {
  PutU32(static_cast<uint32_t>(v), p);
  PutU32(static_cast<uint32_t>(v >> 32), p + 4);
}

constexpr size_t kVersionOffset = 8;
constexpr size_t kFlagsOffset = 12;
constexpr size_t kPayloadBytesOffset = 16;
constexpr size_t kPayloadCrcOffset = 24;
constexpr size_t kHeaderCrcOffset = 28;

std::string Hex(uint32_t v) {
  std::ostringstream out;
  out << "0x" << std::hex << v;
  return out.str();
}

std::string Label(const std::string& name) { return "map file '" + name + "'"; }

Status Truncated(const std::string& name, uint64_t expected, size_t found) {
  return DataLoss(Label(name) + " is truncated: expected " + std::to_string(expected) +
                  " bytes, found " + std::to_string(found));
}

// Checks magic and version, the parts every version shares.
Status CheckPreamble(const char* data, size_t size, const std::string& name) {
  if (size == 0) return DataLoss(Label(name) + " is empty");
  if (std::memcmp(data, kMapMagic, std::min(size, sizeof(kMapMagic))) != 0) {
    return InvalidArgument(Label(name) + " is not a sceneloc map (bad magic)");
  }
  if (size < kFlagsOffset) return Truncated(name, kMapHeaderBytes, size);
  // Checked before the header CRC: a newer version may lay out its header differently.
  const uint32_t version = GetU32(data + kVersionOffset);
  if (version > kMapFormatVersion) {
    return Unimplemented(Label(name) + " has format version " + std::to_string(version) +
                         ", this build reads up to " + std::to_string(kMapFormatVersion) +
                         "; upgrade sceneloc");
  }
  if (version == 0) return DataLoss(Label(name) + " has invalid format version 0 (corrupt file)");
  return Status::Ok();
}

// Checks the header and that the payload it announces is exactly what follows it.
StatusOr<MapFileInfo> ParseHeader(const char* data, size_t size, const std::string& name) {
  SCENELOC_RETURN_IF_ERROR(CheckPreamble(data, size, name));
  if (size < kMapHeaderBytes) return Truncated(name, kMapHeaderBytes, size);
  const uint32_t stored = GetU32(data + kHeaderCrcOffset);
  const uint32_t computed = Crc32(data, kHeaderCrcOffset);
  if (stored != computed) {
    return DataLoss(Label(name) + " header checksum mismatch: stored " + Hex(stored) +
                    ", computed " + Hex(computed) + " (corrupt file)");
  }
  if (const uint32_t flags = GetU32(data + kFlagsOffset); flags != 0) {
    return Unimplemented(Label(name) + " has header flags " + Hex(flags) +
                         " that this build does not know; upgrade sceneloc");
  }
  MapFileInfo info;
  info.format_version = GetU32(data + kVersionOffset);
  info.payload_bytes = GetU64(data + kPayloadBytesOffset);
  info.checksum = GetU32(data + kPayloadCrcOffset);
  const size_t available = size - kMapHeaderBytes;
  if (info.payload_bytes > available) {
    const uint64_t max_payload = std::numeric_limits<uint64_t>::max() - kMapHeaderBytes;
    return Truncated(name, kMapHeaderBytes + std::min(info.payload_bytes, max_payload), size);
  }
  if (info.payload_bytes < available) {
    return DataLoss(Label(name) + " has " + std::to_string(available - info.payload_bytes) +
                    " unexpected bytes after the payload");
  }
  return info;
}

// Reads the payload's fields (the reader's bytes are not yet known to be intact) and, when
// they parse, validates and finalises the map.
// Version-1 maps are brought to today's terms (UpgradeV1).
StatusOr<Map> ReadPayload(PayloadReader& reader, const MapFileInfo& info, const std::string& name) {
  Map map;
  V1Fields v1;
  TransferMap(reader, map, info.format_version, v1);
  if (!reader.status().ok()) {
    if (reader.status().code() == StatusCode::kDataLoss) {
      return DataLoss(Label(name) + " is malformed: " + reader.status().message());
    }
    return reader.status();
  }
  if (reader.remaining() != 0) {
    return DataLoss(Label(name) + " is malformed: " + std::to_string(reader.remaining()) +
                    " payload bytes follow the last field");
  }
  if (info.format_version == 1) UpgradeV1(v1, &map);
  return map;
}

Status ChecksumMismatch(const std::string& name, uint32_t computed, uint32_t stored) {
  return DataLoss(Label(name) + " checksum mismatch: payload CRC-32 is " + Hex(computed) +
                  ", header says " + Hex(stored) + " (corrupt file)");
}

StatusOr<Map> FinishMap(Map map, const MapFileInfo& info, const std::string& name,
                        MapFileInfo* info_out) {
  if (Status valid = map.Validate(); !valid.ok()) {
    return DataLoss(Label(name) + ": " + valid.message());
  }
  map.Finalize();
  if (info_out != nullptr) *info_out = info;
  return map;
}

StatusOr<Map> ParseBuffer(const char* data, size_t size, const std::string& name,
                          MapFileInfo* info_out) {
  SCENELOC_ASSIGN_OR_RETURN(const MapFileInfo info, ParseHeader(data, size, name));
  const char* payload = data + kMapHeaderBytes;
  const uint32_t computed = Crc32(payload, info.payload_bytes);
  if (computed != info.checksum) return ChecksumMismatch(name, computed, info.checksum);
  MemorySource source(payload);
  PayloadReader reader(&source, info.payload_bytes);
  SCENELOC_ASSIGN_OR_RETURN(Map map, ReadPayload(reader, info, name));
  return FinishMap(std::move(map), info, name, info_out);
}

// --- Files ---

Status OsError(const std::string& what, const std::string& path, int error) {
  return IoError(what + " '" + path + "': " + std::strerror(error));
}

// Writes all of `bytes` to `fd` and fsyncs it. `path` names the file in errors.
Status WriteAndSync(int fd, const std::string& bytes, const std::string& path) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return OsError("cannot write", path, errno);
    done += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0) return OsError("cannot fsync", path, errno);
  return Status::Ok();
}

// Makes a completed rename in `dir` durable.
Status SyncDirectory(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return OsError("cannot open directory", dir, errno);
  const int result = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  if (result != 0) return OsError("cannot fsync directory", dir, error);
  return Status::Ok();
}

// Writes `tmp` completely, or removes it and returns why not.
Status WriteTemporary(const std::string& tmp, const std::string& bytes) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return OsError("cannot create temporary map file", tmp, errno);
  Status status = WriteAndSync(fd, bytes, tmp);
  if (::close(fd) != 0 && status.ok()) status = OsError("cannot close", tmp, errno);
  if (!status.ok()) ::unlink(tmp.c_str());
  return status;
}

Status WriteFileAtomically(const std::string& path, const std::string& bytes) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  SCENELOC_RETURN_IF_ERROR(WriteTemporary(tmp, bytes));
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    ::unlink(tmp.c_str());
    return OsError("cannot rename '" + tmp + "' to map file", path, error);
  }
  std::string dir = std::filesystem::path(path).parent_path().string();
  return SyncDirectory(dir.empty() ? "." : dir);
}

// A map file's payload read as it is parsed: small fields through a 64 KiB buffer, arrays
// straight into their destination; the CRC-32 of every byte delivered is kept.
class FileSource : public ByteSource {
 public:
  FileSource(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}

  Status Read(void* out, size_t n) override {
    char* to = static_cast<char*>(out);
    const size_t from_buffer = std::min(n, end_ - begin_);
    if (from_buffer > 0) std::memcpy(to, buffer_.data() + begin_, from_buffer);
    begin_ += from_buffer;
    size_t done = from_buffer;
    if (done < n && n - done >= buffer_.size()) {  // large: no copy through the buffer
      SCENELOC_RETURN_IF_ERROR(ReadFully(to + done, n - done));
      done = n;
    }
    while (done < n) {
      SCENELOC_RETURN_IF_ERROR(Refill());
      const size_t take = std::min(n - done, end_ - begin_);
      std::memcpy(to + done, buffer_.data() + begin_, take);
      begin_ += take;
      done += take;
    }
    crc_ = Crc32(out, n, crc_);
    return Status::Ok();
  }

  // Reads and checksums `n` more bytes without keeping them.
  Status Skip(size_t n) {
    while (n > 0) {
      const size_t take = std::min(n, buffer_.size());
      SCENELOC_RETURN_IF_ERROR(Read(scratch_.data(), take));
      n -= take;
    }
    return Status::Ok();
  }

  uint32_t crc() const { return crc_; }

 private:
  Status Refill() {
    begin_ = 0;
    end_ = 0;
    for (;;) {
      const ssize_t got = ::read(fd_, buffer_.data(), buffer_.size());
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) return OsError("cannot read map file", path_, errno);
      if (got == 0) return Shrunk();
      end_ = static_cast<size_t>(got);
      return Status::Ok();
    }
  }
  Status ReadFully(char* to, size_t n) {
    while (n > 0) {
      const ssize_t got = ::read(fd_, to, std::min<size_t>(n, 1 << 30));
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) return OsError("cannot read map file", path_, errno);
      if (got == 0) return Shrunk();
      to += got;
      n -= static_cast<size_t>(got);
    }
    return Status::Ok();
  }
  Status Shrunk() const {
    return DataLoss(Label(path_) + " is truncated: it ended before its payload did (was it " +
                    "being written or truncated while it was read?)");
  }

  int fd_;
  std::string path_;
  std::vector<char> buffer_ = std::vector<char>(64 * 1024);
  std::vector<char> scratch_ = std::vector<char>(64 * 1024);
  size_t begin_ = 0, end_ = 0;
  uint32_t crc_ = 0;
};

// Closes a file descriptor on every path out.
class FdCloser {
 public:
  explicit FdCloser(int fd) : fd_(fd) {}
  ~FdCloser() { ::close(fd_); }
  FdCloser(const FdCloser&) = delete;
  FdCloser& operator=(const FdCloser&) = delete;

 private:
  int fd_;
};

// Reads up to `n` bytes from the start of the file (fewer if it is shorter).
StatusOr<size_t> ReadPrefix(int fd, char* out, size_t n, const std::string& path) {
  size_t done = 0;
  while (done < n) {
    const ssize_t got = ::read(fd, out + done, n - done);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) return OsError("cannot read map file", path, errno);
    if (got == 0) break;
    done += static_cast<size_t>(got);
  }
  return done;
}

std::string FormatBytes(uint64_t bytes) {
  std::ostringstream out;
  out << bytes << " bytes";
  if (bytes >= (uint64_t{1} << 20)) {
    out.precision(1);
    out << std::fixed << " (" << static_cast<double>(bytes) / (1 << 20) << " MiB)";
  }
  return out.str();
}

// The header, then the limit, then the payload streamed with its CRC: a file's declared
// sizes are checked before a byte of its payload is read or any memory is set aside for it.
StatusOr<Map> LoadFromFile(int fd, const std::string& path, uint64_t file_size,
                           const MapLoadOptions& options, MapFileInfo* info_out) {
  char header[kMapHeaderBytes];
  SCENELOC_ASSIGN_OR_RETURN(const size_t got, ReadPrefix(fd, header, sizeof(header), path));
  if (got < std::min<uint64_t>(file_size, kMapHeaderBytes)) {
    return DataLoss(Label(path) + " is truncated: it shrank while it was read");
  }
  SCENELOC_ASSIGN_OR_RETURN(const MapFileInfo info,
                            ParseHeader(header, static_cast<size_t>(file_size), path));
  if (file_size > options.max_file_bytes) {
    return ResourceExhausted(
        Label(path) + " is " + FormatBytes(file_size) +
        ", above the limit max_map_bytes = " + FormatBytes(options.max_file_bytes));
  }
  FileSource source(fd, path);
  PayloadReader reader(&source, static_cast<size_t>(info.payload_bytes));
  StatusOr<Map> map = ReadPayload(reader, info, path);
  if (!map.ok() && map.status().code() != StatusCode::kDataLoss) return map.status();
  if (!map.ok()) {
    // A malformed payload is most often a corrupt one: say so if the checksum agrees.
    if (!source.Skip(reader.remaining()).ok()) return map.status();
  }
  if (source.crc() != info.checksum) return ChecksumMismatch(path, source.crc(), info.checksum);
  if (!map.ok()) return map.status();
  return FinishMap(std::move(map).value(), info, path, info_out);
}

}  // namespace

std::string SerializeMap(const Map& map) {
  std::string out(kMapHeaderBytes, '\0');
  out.reserve(kMapHeaderBytes + map.MemoryBytes());  // slightly more than the payload
  PayloadWriter writer(&out);
  V1Fields unused;
  TransferMap(writer, map, kMapFormatVersion, unused);
  char* header = out.data();
  std::memcpy(header, kMapMagic, sizeof(kMapMagic));
  PutU32(kMapFormatVersion, header + kVersionOffset);
  PutU32(0, header + kFlagsOffset);
  PutU64(out.size() - kMapHeaderBytes, header + kPayloadBytesOffset);
  PutU32(Crc32(header + kMapHeaderBytes, out.size() - kMapHeaderBytes), header + kPayloadCrcOffset);
  PutU32(Crc32(header, kHeaderCrcOffset), header + kHeaderCrcOffset);
  return out;
}

Status SaveMap(const Map& map, const std::string& path, MapFileInfo* info) {
  if (Status valid = map.Validate(); !valid.ok()) {
    return InvalidArgument("refusing to save an invalid map to '" + path + "': " + valid.message());
  }
  const std::string bytes = SerializeMap(map);
  SCENELOC_RETURN_IF_ERROR(WriteFileAtomically(path, bytes));
  if (info != nullptr) {
    info->format_version = kMapFormatVersion;
    info->payload_bytes = GetU64(bytes.data() + kPayloadBytesOffset);
    info->checksum = GetU32(bytes.data() + kPayloadCrcOffset);
  }
  return Status::Ok();
}

StatusOr<Map> LoadMap(const std::string& path, MapFileInfo* info, const MapLoadOptions& options) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0 && errno == ENOENT) return NotFound(Label(path) + " does not exist");
  if (fd < 0) return OsError("cannot open map file", path, errno);
  FdCloser closer(fd);
  struct stat st {};
  if (::fstat(fd, &st) != 0) return OsError("cannot stat map file", path, errno);
  if (!S_ISREG(st.st_mode)) return IoError("cannot read " + Label(path) + ": not a regular file");
  (void)::posix_fadvise(fd, 0, 0, POSIX_FADV_SEQUENTIAL);
  return LoadFromFile(fd, path, static_cast<uint64_t>(st.st_size), options, info);
}

StatusOr<Map> ParseMap(const std::string& bytes, const std::string& name_for_errors,
                       MapFileInfo* info) {
  return ParseBuffer(bytes.data(), bytes.size(), name_for_errors, info);
}

}  // namespace sceneloc
