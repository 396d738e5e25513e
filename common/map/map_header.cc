#include "common/map/map_header.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <sstream>

#include "common/map/crc32.h"

namespace sceneloc::map_io_internal {
namespace {

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

// The payload the header announces must be exactly what follows it.
Status CheckPayloadSize(const MapFileInfo& info, size_t size, const std::string& name) {
  const size_t available = size - kMapHeaderBytes;
  if (info.payload_bytes > available) {
    const uint64_t max_payload = std::numeric_limits<uint64_t>::max() - kMapHeaderBytes;
    return Truncated(name, kMapHeaderBytes + std::min(info.payload_bytes, max_payload), size);
  }
  if (info.payload_bytes < available) {
    return DataLoss(Label(name) + " has " + std::to_string(available - info.payload_bytes) +
                    " unexpected bytes after the payload");
  }
  return Status::Ok();
}

}  // namespace

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

void WriteHeader(uint64_t payload_bytes, uint32_t payload_crc, char* header) {
  std::memcpy(header, kMapMagic, sizeof(kMapMagic));
  PutU32(kMapFormatVersion, header + kVersionOffset);
  PutU32(0, header + kFlagsOffset);
  PutU64(payload_bytes, header + kPayloadBytesOffset);
  PutU32(payload_crc, header + kPayloadCrcOffset);
  PutU32(Crc32(header, kHeaderCrcOffset), header + kHeaderCrcOffset);
}

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
  SCENELOC_RETURN_IF_ERROR(CheckPayloadSize(info, size, name));
  return info;
}

}  // namespace sceneloc::map_io_internal
