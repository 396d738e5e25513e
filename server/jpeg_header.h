// Reads a JPEG's dimensions from its header without decoding it, so the server can refuse
// a huge image before the decoder (common/image) allocates its pixels.
//
// Thread-safe: a pure function.
#pragma once

#include <cstdint>
#include <string_view>

#include "common/util/status.h"

namespace sceneloc {

struct JpegDimensions {
  int width = 0;
  int height = 0;
  int components = 0;  // 1 (grey) or 3 (colour), as the frame header says
  // A progressive (or other multi-scan) frame: the decoder keeps every coefficient of
  // the whole image in memory until the last scan.
  bool progressive = false;
};

// An upper bound on the memory that decoding a JPEG of `dims` holds at its peak, bytes:
// a 3-byte-per-pixel decoded image, plus for a progressive JPEG the decoder's
// coefficient arrays (2 bytes per pixel per component, without chroma subsampling).
int64_t EstimateDecodeBytes(const JpegDimensions& dims);

// Walks the marker segments from SOI to the first start-of-frame (SOF0..SOF15 except
// DHT, JPG and DAC) and returns its size. Errors (InvalidArgument): not a JPEG, a
// segment running past the end, no frame header before the scan, a zero dimension (a
// DNL-defined height is refused too), a marker libjpeg would not read as a header segment
// (it resynchronises past those, so skipping them by a length could hide the frame header
// the decoder uses). Never reads outside `bytes`.
StatusOr<JpegDimensions> ReadJpegDimensions(std::string_view bytes);

// The number of scans (start-of-scan markers) in the whole JPEG, walking the marker
// segments and skipping each scan's entropy-coded data; stops at the end-of-image marker
// or the end of `bytes`. A baseline JPEG has 1 scan, a progressive one about 10; decoding
// costs a full pass over the image per scan, so a JPEG of thousands of scans is a
// decompression bomb. Linear in the size, never reads outside `bytes`.
int CountJpegScans(std::string_view bytes);

}  // namespace sceneloc
