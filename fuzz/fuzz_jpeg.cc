// libFuzzer target: JPEG bytes as a localise request carries them, through the server's
// checks in order: the header's dimensions and scan count (server/jpeg_header.h), then,
// within limits, the decode (OpenCV/libjpeg). Extraction from what decodes is fuzz_handler's
// (SIFT under ASan would bring this target down to a few inputs a second).
//
// Oracle beyond the sanitizers: the decoder never produces more pixels than the header
// check saw. If it did, a small header could smuggle a large image past every limit.
#include <algorithm>
#include <cstdlib>
#include <string>

#include "common/features/extractor.h"
#include "server/jpeg_header.h"

namespace {

// Smaller than the server's limits (4096 per side, 64 scans) so that each input takes
// milliseconds; the code paths are the same.
constexpr int kMaxSide = 1024;
constexpr int kMaxScans = 64;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace sceneloc;
  const std::string jpeg(reinterpret_cast<const char*>(data), size);
  auto dims = ReadJpegDimensions(jpeg);
  if (!dims.ok()) return 0;
  if (dims->width > kMaxSide || dims->height > kMaxSide) return 0;
  if (CountJpegScans(jpeg) > kMaxScans) return 0;
  auto image = DecodeImage(jpeg, kMaxSide);
  if (!image.ok()) return 0;
  // OpenCV may turn the image by its EXIF orientation, so compare the long sides.
  if (std::max(image->cols, image->rows) > std::max(dims->width, dims->height) ||
      std::min(image->cols, image->rows) > std::min(dims->width, dims->height)) {
    std::abort();
  }
  return 0;
}
