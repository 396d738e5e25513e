#include "common/map/crc32.h"

#include <array>
#include <cstring>

#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "crc32.cc reads input words as little-endian"
#endif

namespace sceneloc {
namespace {

constexpr uint32_t kPolynomial = 0xEDB88320u;
constexpr int kSlices = 16;

// Slicing-by-16 tables: table[0] is the classic byte-at-a-time table; table[k][b] is the
// CRC of byte b followed by k zero bytes, so 16 input bytes cost 16 independent lookups.
// 16 KB of tables; about 4.5 GB/s on the development machine against 2.5 GB/s for
// slicing-by-8 and 0.5 GB/s byte by byte, which matters for a 30 MB map loaded in
// milliseconds.
using Tables = std::array<std::array<uint32_t, 256>, kSlices>;

constexpr Tables MakeTables() {
  Tables t{};
  for (uint32_t b = 0; b < 256; ++b) {
    uint32_t crc = b;
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ ((crc & 1u) ? kPolynomial : 0u);
    t[0][b] = crc;
  }
  for (int k = 1; k < kSlices; ++k) {
    for (uint32_t b = 0; b < 256; ++b) t[k][b] = (t[k - 1][b] >> 8) ^ t[0][t[k - 1][b] & 0xFFu];
  }
  return t;
}

constexpr Tables kTables = MakeTables();

// memcpy: the input need not be 4-byte aligned.
uint32_t Load32(const unsigned char* p) {
  uint32_t v;
  std::memcpy(&v, p, sizeof(v));
  return v;
}

// Folds the four bytes of `word` through the tables of slices first..first-3.
uint32_t Fold(uint32_t word, int first) {
  return kTables[first][word & 0xFFu] ^ kTables[first - 1][(word >> 8) & 0xFFu] ^
         kTables[first - 2][(word >> 16) & 0xFFu] ^ kTables[first - 3][word >> 24];
}

}  // namespace

uint32_t Crc32(const void* data, size_t size, uint32_t crc) {
  const auto* p = static_cast<const unsigned char*>(data);
  crc = ~crc;
  for (; size >= kSlices; size -= kSlices, p += kSlices) {
    crc = Fold(Load32(p) ^ crc, 15) ^ Fold(Load32(p + 4), 11) ^ Fold(Load32(p + 8), 7) ^
          Fold(Load32(p + 12), 3);
  }
  for (; size > 0; --size, ++p) crc = (crc >> 8) ^ kTables[0][(crc ^ *p) & 0xFFu];
  return ~crc;
}

}  // namespace sceneloc
