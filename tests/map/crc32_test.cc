// CRC-32 (common/map/crc32.h): the standard check value, pieces, and every length and
// alignment against a bit-by-bit reference.
#include "common/map/crc32.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

namespace sceneloc {
namespace {

// The textbook CRC-32, one bit at a time: slow, and plainly the specification.
uint32_t BitwiseCrc32(const unsigned char* p, size_t n) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) {
    crc ^= p[i];
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

// CRC-32 matches the standard check value and can be computed in pieces.
TEST(Crc32Test, MatchesStandardCheckValue) {
  const std::string text = "123456789";
  EXPECT_EQ(Crc32(text.data(), text.size()), 0xCBF43926u);
  EXPECT_EQ(Crc32(nullptr, 0), 0u);
  const std::string long_text(1000, 'x');
  EXPECT_EQ(Crc32(long_text.data() + 3, 997, Crc32(long_text.data(), 3)),
            Crc32(long_text.data(), 1000));
}

// Every length from 0 to 100 bytes, at every start offset modulo 16 (the table-driven
// loop takes 16 bytes at a time, unaligned), agrees with the bit-by-bit reference.
TEST(Crc32Test, AgreesWithBitwiseReferenceAtEveryLengthAndAlignment) {
  std::mt19937 rng(11);
  std::vector<unsigned char> bytes(200);
  for (unsigned char& b : bytes) b = static_cast<unsigned char>(rng());
  for (size_t start = 0; start < 16; ++start) {
    for (size_t n = 0; n <= 100; ++n) {
      ASSERT_EQ(Crc32(bytes.data() + start, n), BitwiseCrc32(bytes.data() + start, n))
          << "start " << start << ", " << n << " bytes";
    }
  }
}

// Any split of a buffer into two pieces gives the checksum of the whole.
TEST(Crc32Test, PiecesAtEverySplitGiveTheWhole) {
  std::mt19937 rng(12);
  std::vector<unsigned char> bytes(70);
  for (unsigned char& b : bytes) b = static_cast<unsigned char>(rng());
  const uint32_t whole = Crc32(bytes.data(), bytes.size());
  for (size_t cut = 0; cut <= bytes.size(); ++cut) {
    EXPECT_EQ(Crc32(bytes.data() + cut, bytes.size() - cut, Crc32(bytes.data(), cut)), whole)
        << "cut at " << cut;
  }
}

// One flipped bit anywhere changes the checksum.
TEST(Crc32Test, DetectsEverySingleBitFlip) {
  std::vector<unsigned char> bytes(40, 0x5A);
  const uint32_t clean = Crc32(bytes.data(), bytes.size());
  for (size_t i = 0; i < bytes.size() * 8; ++i) {
    bytes[i / 8] ^= static_cast<unsigned char>(1u << (i % 8));
    EXPECT_NE(Crc32(bytes.data(), bytes.size()), clean) << "bit " << i;
    bytes[i / 8] ^= static_cast<unsigned char>(1u << (i % 8));
  }
}

}  // namespace
}  // namespace sceneloc
