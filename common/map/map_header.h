// The 32-byte header of a map file (layout in map_io.h): written in front of a payload,
// and checked before a byte of the payload is trusted. Also the wording that every error
// about a map file shares. Internal to map_io.
//
// Thread-safe: free functions without shared state.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "common/map/map_io.h"
#include "common/util/status.h"

namespace sceneloc::map_io_internal {

// Byte offsets of the header fields (the magic is at 0).
inline constexpr size_t kVersionOffset = 8;
inline constexpr size_t kFlagsOffset = 12;
inline constexpr size_t kPayloadBytesOffset = 16;
inline constexpr size_t kPayloadCrcOffset = 24;
inline constexpr size_t kHeaderCrcOffset = 28;

// Little-endian integers at `p`, whatever the host's byte order.
uint32_t GetU32(const char* p);
uint64_t GetU64(const char* p);
void PutU32(uint32_t v, char* p);
void PutU64(uint64_t v, char* p);

// "0x" and `v` in lower-case hexadecimal.
std::string Hex(uint32_t v);
// "map file '<name>'": how every error names the file (or the stand-in name).
std::string Label(const std::string& name);
// DataLoss: the file named `name` is `found` bytes where `expected` were due.
Status Truncated(const std::string& name, uint64_t expected, size_t found);

// Writes a complete header for a payload of `payload_bytes` bytes whose CRC-32 is
// `payload_crc`, in the current format version, to header[0 .. kMapHeaderBytes).
void WriteHeader(uint64_t payload_bytes, uint32_t payload_crc, char* header);

// Checks the header in data[0 .. size) (`size` is the whole file's size: the header must
// announce exactly the payload that follows it) and returns what it says. Errors name the
// file as `name`: DataLoss (empty, truncated, header checksum mismatch, version 0, bytes
// after the payload), InvalidArgument (bad magic), Unimplemented (a newer version or
// unknown flags). REQUIRES: min(size, kMapHeaderBytes) bytes readable at `data`.
StatusOr<MapFileInfo> ParseHeader(const char* data, size_t size, const std::string& name);

}  // namespace sceneloc::map_io_internal
