// CRC-32 (IEEE 802.3: polynomial 0xEDB88320 reflected, initial value and final XOR
// 0xFFFFFFFF), the checksum zlib, PNG and gzip use. Crc32("123456789") == 0xCBF43926.
//
// Thread-safe: pure functions over caller-owned bytes.
#pragma once

#include <cstddef>
#include <cstdint>

namespace sceneloc {

// Returns the CRC-32 of `size` bytes at `data`. To checksum data in pieces, pass the
// previous result as `crc`: Crc32(b, nb, Crc32(a, na)) == Crc32 of a followed by b.
uint32_t Crc32(const void* data, size_t size, uint32_t crc = 0);

}  // namespace sceneloc
