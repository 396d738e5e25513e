#include "server/jpeg_header.h"

#include <cstdint>
#include <string>

namespace sceneloc {
namespace {

uint8_t At(std::string_view b, size_t i) { return static_cast<uint8_t>(b[i]); }
int Be16(std::string_view b, size_t i) { return (At(b, i) << 8) | At(b, i + 1); }

// Start-of-frame markers carry the image size; C4 (DHT), C8 (JPG) and CC (DAC) share the
// range but are not frames.
bool IsStartOfFrame(uint8_t marker) {
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
}

// Markers without a length field: TEM and RST0..RST7.
bool IsStandalone(uint8_t marker) { return marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7); }

// The segments libjpeg reads (or skips) by their length before the first scan: frames and
// their tables (C0..CF), DNL, DQT, DRI, APP0..APP15 and COM. libjpeg refuses every other
// marker there, so we do too: a marker we skipped by its length while libjpeg resynchronised
// inside it is how a small frame header could hide the one the decoder uses.
bool IsHeaderSegment(uint8_t marker) {
  return (marker >= 0xC0 && marker <= 0xCF) || marker == 0xDB || marker == 0xDC || marker == 0xDD ||
         (marker >= 0xE0 && marker <= 0xEF) || marker == 0xFE;
}

std::string Hex(uint8_t marker) {
  static const char kDigits[] = "0123456789ABCDEF";
  return std::string("0x") + kDigits[marker >> 4] + kDigits[marker & 0xF];
}

}  // namespace

StatusOr<JpegDimensions> ReadJpegDimensions(std::string_view b) {
  if (b.size() < 4 || At(b, 0) != 0xFF || At(b, 1) != 0xD8) {
    return InvalidArgument("image is not a JPEG (no start-of-image marker)");
  }
  size_t pos = 2;
  while (pos < b.size()) {
    if (At(b, pos) != 0xFF) return InvalidArgument("JPEG header is corrupt (expected a marker)");
    while (pos < b.size() && At(b, pos) == 0xFF) ++pos;  // fill bytes
    if (pos >= b.size()) break;
    const uint8_t marker = At(b, pos++);
    if (IsStandalone(marker)) continue;
    if (marker == 0xD9 || marker == 0xDA) break;  // end of image or start of scan: no frame
    if (!IsHeaderSegment(marker)) {
      // 0x00 included: libjpeg takes 0xFF00 for garbage and searches on for a marker.
      return InvalidArgument("JPEG header is corrupt (marker " + Hex(marker) +
                             " where a header segment should be)");
    }
    if (pos + 2 > b.size()) break;
    const size_t length = static_cast<size_t>(Be16(b, pos));
    if (length < 2 || pos + length > b.size()) break;
    if (IsStartOfFrame(marker)) {
      if (length < 8) return InvalidArgument("JPEG frame header is too short");
      JpegDimensions d;
      d.height = Be16(b, pos + 3);
      d.width = Be16(b, pos + 5);
      d.components = At(b, pos + 7);
      // SOF2, SOF6, SOF10, SOF14: progressive (Huffman or arithmetic, plain or differential).
      d.progressive = marker == 0xC2 || marker == 0xC6 || marker == 0xCA || marker == 0xCE;
      if (d.width == 0 || d.height == 0) {
        return InvalidArgument("JPEG frame header gives a zero width or height");
      }
      return d;
    }
    pos += length;
  }
  return InvalidArgument("JPEG is truncated or corrupt: no frame header before the image data");
}

int64_t EstimateDecodeBytes(const JpegDimensions& dims) {
  const int64_t pixels = static_cast<int64_t>(dims.width) * dims.height;
  return pixels * 3 + (dims.progressive ? pixels * 2 * dims.components : 0);
}

int CountJpegScans(std::string_view b) {
  int scans = 0;
  size_t pos = 2;  // after SOI
  while (pos + 1 < b.size()) {
    if (At(b, pos) != 0xFF) {  // entropy-coded data: find the next marker
      ++pos;
      continue;
    }
    const uint8_t marker = At(b, pos + 1);
    if (marker == 0x00 || marker == 0xFF || IsStandalone(marker)) {  // stuffing, fill, RSTn
      pos += marker == 0xFF ? 1 : 2;
      continue;
    }
    if (marker == 0xD9) break;  // end of image
    if (pos + 4 > b.size()) break;
    const size_t length = static_cast<size_t>(Be16(b, pos + 2));
    if (length < 2) break;
    if (marker == 0xDA) ++scans;
    pos += 2 + length;  // the segment; a scan's data follows it
  }
  return scans;
}

}  // namespace sceneloc
