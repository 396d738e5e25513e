#include "common/map/map_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <sstream>
#include <utility>

#include "common/map/crc32.h"
#include "common/map/map_file_io.h"
#include "common/map/map_header.h"
#include "common/map/map_layout.h"
#include "common/map/payload_archive.h"

// The format's parts live beside this file: the header (map_header.h), the field codec
// (payload_archive.h), the payload layout (map_layout.h) and the file system
// (map_file_io.h). This file puts them together.

namespace sceneloc {
namespace {

using map_io_internal::FdCloser;
using map_io_internal::FileSource;
using map_io_internal::GetU32;
using map_io_internal::GetU64;
using map_io_internal::Hex;
using map_io_internal::kPayloadBytesOffset;
using map_io_internal::kPayloadCrcOffset;
using map_io_internal::Label;
using map_io_internal::MemorySource;
using map_io_internal::ParseHeader;
using map_io_internal::PayloadReader;
using map_io_internal::PayloadWriter;
using map_io_internal::ReadPrefix;
using map_io_internal::V1Fields;

// Reads the payload's fields (the reader's bytes are not yet known to be intact) and, when
// they parse, validates and finalises the map.
// Version-1 maps are brought to today's terms (UpgradeV1).
StatusOr<Map> ReadPayload(PayloadReader& reader, const MapFileInfo& info, const std::string& name) {
  Map map;
  V1Fields v1;
  map_io_internal::TransferMap(reader, map, info.format_version, v1);
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
  if (info.format_version == 1) map_io_internal::UpgradeV1(v1, &map);
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
  map_io_internal::TransferMap(writer, map, kMapFormatVersion, unused);
  const uint64_t payload_bytes = out.size() - kMapHeaderBytes;
  map_io_internal::WriteHeader(payload_bytes, Crc32(out.data() + kMapHeaderBytes, payload_bytes),
                               out.data());
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
