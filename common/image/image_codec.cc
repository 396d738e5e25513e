#include "common/image/image_codec.h"

#include <png.h>
#include <turbojpeg.h>

#include <cstdint>
#include <cstring>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace sceneloc {
namespace {

constexpr unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

std::string Size(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

Status TooLarge(int width, int height, int max_side) {
  return ResourceExhausted("image is " + Size(width, height) + ", larger than " +
                           std::to_string(max_side) + " pixels per side");
}

// ---------------------------------------------------------------- EXIF orientation

uint32_t ReadUnsigned(const unsigned char* p, int bytes, bool little_endian) {
  uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) {
    const uint32_t b = p[little_endian ? bytes - 1 - i : i];
    v = (v << 8) | b;
  }
  return v;
}

// The orientation tag (0x0112) of IFD0 in a TIFF block, 1 when absent or malformed.
int TiffOrientation(const unsigned char* tiff, size_t size) {
  if (size < 8) return 1;
  bool little;
  if (tiff[0] == 'I' && tiff[1] == 'I') {
    little = true;
  } else if (tiff[0] == 'M' && tiff[1] == 'M') {
    little = false;
  } else {
    return 1;
  }
  if (ReadUnsigned(tiff + 2, 2, little) != 42) return 1;
  const uint32_t ifd = ReadUnsigned(tiff + 4, 4, little);
  if (ifd > size - 2) return 1;
  const uint32_t entries = ReadUnsigned(tiff + ifd, 2, little);
  for (uint32_t e = 0; e < entries; ++e) {
    const size_t at = size_t{ifd} + 2 + size_t{e} * 12;
    if (at + 12 > size) return 1;
    const unsigned char* entry = tiff + at;
    const uint32_t tag = ReadUnsigned(entry, 2, little);
    const uint32_t type = ReadUnsigned(entry + 2, 2, little);
    if (tag != 0x0112) continue;
    if (type != 3) return 1;  // SHORT, as the standard has it
    const uint32_t value = ReadUnsigned(entry + 8, 2, little);
    return value >= 1 && value <= 8 ? static_cast<int>(value) : 1;
  }
  return 1;
}

// The EXIF orientation of a JPEG: the first APP1 "Exif" segment before the first scan.
// Walks the marker segments by their lengths; never reads outside `bytes`.
int JpegOrientation(std::string_view bytes) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  const size_t n = bytes.size();
  size_t at = 2;  // past SOI
  while (at + 4 <= n) {
    if (p[at] != 0xFF) return 1;
    const unsigned char marker = p[at + 1];
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    if (marker == 0xD8 || (marker >= 0xD0 && marker <= 0xD7) || marker == 0x01) {
      at += 2;  // segments without a length
      continue;
    }
    if (marker == 0xDA || marker == 0xD9) return 1;  // the scan or the end: no EXIF before it
    const size_t length = ReadUnsigned(p + at + 2, 2, false);
    if (length < 2 || at + 2 + length > n) return 1;
    const unsigned char* data = p + at + 4;
    const size_t size = length - 2;
    if (marker == 0xE1 && size >= 6 && std::memcmp(data, "Exif\0\0", 6) == 0) {
      return TiffOrientation(data + 6, size - 6);
    }
    at += 2 + length;
  }
  return 1;
}

// Turns the image as the EXIF orientation says, exactly as imgcodecs' ApplyExifOrientation.
void ApplyOrientation(int orientation, cv::Mat* image) {
  switch (orientation) {
    case 2:
      cv::flip(*image, *image, 1);
      break;
    case 3:
      cv::flip(*image, *image, -1);
      break;
    case 4:
      cv::flip(*image, *image, 0);
      break;
    case 5:
      cv::transpose(*image, *image);
      break;
    case 6:
      cv::transpose(*image, *image);
      cv::flip(*image, *image, 1);
      break;
    case 7:
      cv::transpose(*image, *image);
      cv::flip(*image, *image, -1);
      break;
    case 8:
      cv::transpose(*image, *image);
      cv::flip(*image, *image, 0);
      break;
    default:
      break;
  }
}

// ---------------------------------------------------------------- JPEG

struct TjDestroy {
  void operator()(void* handle) const { tjDestroy(handle); }
};
using TjHandle = std::unique_ptr<void, TjDestroy>;

std::string TjError(tjhandle handle) { return tjGetErrorStr2(handle); }

StatusOr<cv::Mat> DecodeJpeg(std::string_view bytes, const DecodeOptions& options) {
  const TjHandle handle(tjInitDecompress());
  if (!handle) return Internal(std::string("TurboJPEG: ") + tjGetErrorStr2(nullptr));
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const auto size = static_cast<unsigned long>(bytes.size());  // NOLINT(runtime/int): its API
  int width = 0, height = 0, subsampling = 0, colourspace = 0;
  if (tjDecompressHeader3(handle.get(), data, size, &width, &height, &subsampling, &colourspace) !=
      0) {
    return InvalidArgument("image bytes are not a decodable JPEG: " + TjError(handle.get()));
  }
  if (colourspace == TJCS_CMYK || colourspace == TJCS_YCCK) {
    return InvalidArgument("a CMYK JPEG is not supported; send it as RGB or grey");
  }
  const tjscalingfactor factor = {1, options.reduction};
  const int out_width = TJSCALED(width, factor);
  const int out_height = TJSCALED(height, factor);
  if (out_width > options.max_side || out_height > options.max_side) {
    return TooLarge(out_width, out_height, options.max_side);
  }
  cv::Mat image(out_height, out_width, options.gray ? CV_8UC1 : CV_8UC3);
  const int rc =
      tjDecompress2(handle.get(), data, size, image.data, out_width, static_cast<int>(image.step),
                    out_height, options.gray ? TJPF_GRAY : TJPF_BGR, 0);
  // A warning (data ending early, a corrupt stretch of entropy-coded data) leaves a whole
  // image with the rows past the damage grey: libjpeg goes on after it, as imdecode did
  // (whose rows past the end of the data were left as allocated).
  if (rc != 0 && tjGetErrorCode(handle.get()) != TJERR_WARNING) {
    return InvalidArgument("image bytes could not be decoded as a JPEG: " + TjError(handle.get()));
  }
  ApplyOrientation(JpegOrientation(bytes), &image);
  return image;
}

// ---------------------------------------------------------------- PNG

struct PngFree {
  void operator()(png_image* image) const { png_image_free(image); }
};

StatusOr<cv::Mat> DecodePng(std::string_view bytes, const DecodeOptions& options) {
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  const std::unique_ptr<png_image, PngFree> cleanup(&png);
  if (!png_image_begin_read_from_memory(&png, bytes.data(), bytes.size())) {
    return InvalidArgument(std::string("image bytes are not a decodable PNG: ") + png.message);
  }
  const int width = static_cast<int>(png.width), height = static_cast<int>(png.height);
  if (png.width > static_cast<png_uint_32>(options.max_side) * options.reduction ||
      png.height > static_cast<png_uint_32>(options.max_side) * options.reduction) {
    return TooLarge(width / options.reduction, height / options.reduction, options.max_side);
  }
  // 16-bit samples are read as they are and their low byte dropped afterwards (libpng's
  // png_set_strip_16, as imgcodecs reads them); an alpha channel is read and dropped.
  const bool wide = (png.format & PNG_FORMAT_FLAG_LINEAR) != 0;
  const bool alpha = (png.format & PNG_FORMAT_FLAG_ALPHA) != 0;
  png.format = (alpha ? PNG_FORMAT_BGRA : PNG_FORMAT_BGR) | (wide ? PNG_FORMAT_FLAG_LINEAR : 0);
  cv::Mat read(height, width, CV_MAKETYPE(wide ? CV_16U : CV_8U, alpha ? 4 : 3));
  if (!png_image_finish_read(&png, nullptr, read.data, 0, nullptr)) {
    return InvalidArgument(std::string("image bytes could not be decoded as a PNG: ") +
                           png.message);
  }
  if (wide) {
    cv::Mat narrow(read.size(), CV_MAKETYPE(CV_8U, read.channels()));
    const auto* in = read.ptr<uint16_t>();
    uint8_t* out = narrow.ptr<uint8_t>();
    for (size_t i = 0, n = read.total() * read.channels(); i < n; ++i) out[i] = in[i] >> 8;
    read = narrow;
  }
  cv::Mat image;
  if (options.gray) {
    cv::cvtColor(read, image, alpha ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  } else if (alpha) {
    cv::cvtColor(read, image, cv::COLOR_BGRA2BGR);
  } else {
    image = read;
  }
  if (options.reduction > 1) {
    cv::resize(image, image,
               cv::Size(image.cols / options.reduction, image.rows / options.reduction), 0, 0,
               cv::INTER_LINEAR_EXACT);
  }
  return image;
}

}  // namespace

ImageFormat SniffImageFormat(std::string_view bytes) {
  if (bytes.size() >= 3 && static_cast<unsigned char>(bytes[0]) == 0xFF &&
      static_cast<unsigned char>(bytes[1]) == 0xD8 &&
      static_cast<unsigned char>(bytes[2]) == 0xFF) {
    return ImageFormat::kJpeg;
  }
  if (bytes.size() >= sizeof kPngSignature &&
      std::memcmp(bytes.data(), kPngSignature, sizeof kPngSignature) == 0) {
    return ImageFormat::kPng;
  }
  return ImageFormat::kUnknown;
}

StatusOr<cv::Mat> DecodeImageBytes(std::string_view bytes, const DecodeOptions& options) {
  if (options.reduction != 1 && options.reduction != 2 && options.reduction != 4 &&
      options.reduction != 8) {
    return InvalidArgument("decode reduction must be 1, 2, 4 or 8, not " +
                           std::to_string(options.reduction));
  }
  if (options.max_side < 1) return InvalidArgument("max_side must be at least 1");
  if (bytes.empty()) return InvalidArgument("image bytes are empty");
  switch (SniffImageFormat(bytes)) {
    case ImageFormat::kJpeg:
      return DecodeJpeg(bytes, options);
    case ImageFormat::kPng:
      return DecodePng(bytes, options);
    case ImageFormat::kUnknown:
      break;
  }
  return InvalidArgument("image bytes are not a decodable JPEG or PNG");
}

StatusOr<std::string> EncodeJpeg(const cv::Mat& image, int quality) {
  if (image.empty() || (image.type() != CV_8UC3 && image.type() != CV_8UC1)) {
    return InvalidArgument("a JPEG is encoded from an 8-bit BGR or grey image");
  }
  if (quality < 1 || quality > 100) {
    return InvalidArgument("JPEG quality must be 1..100, not " + std::to_string(quality));
  }
  const TjHandle handle(tjInitCompress());
  if (!handle) return Internal(std::string("TurboJPEG: ") + tjGetErrorStr2(nullptr));
  const bool gray = image.channels() == 1;
  unsigned char* buffer = nullptr;
  unsigned long size = 0;  // NOLINT(runtime/int): its API
  const int rc = tjCompress2(
      handle.get(), image.data, image.cols, static_cast<int>(image.step), image.rows,
      gray ? TJPF_GRAY : TJPF_BGR, &buffer, &size, gray ? TJSAMP_GRAY : TJSAMP_420, quality,
      TJFLAG_ACCURATEDCT);  // imencode's DCT; TurboJPEG's default is the fast one
  const std::unique_ptr<unsigned char, decltype(&tjFree)> owned(buffer, &tjFree);
  if (rc != 0) return Internal("JPEG encoding failed: " + TjError(handle.get()));
  return std::string(reinterpret_cast<const char*>(buffer), size);
}

StatusOr<std::string> EncodePng(const cv::Mat& image) {
  if (image.empty() || (image.type() != CV_8UC3 && image.type() != CV_8UC1)) {
    return InvalidArgument("a PNG is encoded from an 8-bit BGR or grey image");
  }
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.cols);
  png.height = static_cast<png_uint_32>(image.rows);
  png.format = image.channels() == 1 ? PNG_FORMAT_GRAY : PNG_FORMAT_BGR;
  const auto stride = static_cast<png_int_32>(image.step / image.elemSize1());
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&png, nullptr, &size, 0, image.data, stride, nullptr)) {
    return Internal(std::string("PNG encoding failed: ") + png.message);
  }
  std::string bytes(size, '\0');
  if (!png_image_write_to_memory(&png, bytes.data(), &size, 0, image.data, stride, nullptr)) {
    return Internal(std::string("PNG encoding failed: ") + png.message);
  }
  bytes.resize(size);
  return bytes;
}

}  // namespace sceneloc
