// JPEG and PNG to and from cv::Mat through their own libraries: libjpeg-turbo's TurboJPEG
// API for JPEG (decoded at 1/2, 1/4 or 1/8 of its size by DCT scaling when asked) and
// libpng's simplified API for PNG. OpenCV's imgcodecs would do the same, but its Debian
// package pulls in GDAL, HDF5, poppler and their libraries (hundreds of MB in an image);
// the installed programs need these two formats only.
//
// The pixels are OpenCV's for the same bytes and flags: a JPEG decodes exactly as
// cv::imdecode decodes it (same library, same DCT, same colour conversion, the EXIF
// orientation applied the same way), and an 8-bit PNG too (tests/image check both against
// imgcodecs). Not read: CMYK JPEGs, JPEG 2000, WebP, TIFF and the other formats imgcodecs
// knows; they are refused with an error naming what was found.
//
// Thread-safe: pure functions; each call makes its own decoder.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>
#include <string_view>

#include "common/util/status.h"

namespace sceneloc {

enum class ImageFormat { kUnknown, kJpeg, kPng };

// The format the bytes' signature names (JPEG: FF D8 FF, PNG: its 8-byte signature).
ImageFormat SniffImageFormat(std::string_view bytes);

struct DecodeOptions {
  bool gray = false;  // one channel (a JPEG's luma alone: no colour conversion) or BGR
  // 1, 2, 4 or 8: a JPEG is decoded at ceil(size / reduction) by libjpeg's DCT scaling, a PNG
  // in full and then resized to size / reduction (INTER_LINEAR_EXACT), as imdecode's
  // IMREAD_REDUCED_* flags do.
  int reduction = 1;
  // Refused (ResourceExhausted) before any pixel is decoded when the image, as decoded
  // (reduced, before its EXIF turn), is larger than this on either side.
  int max_side = 1 << 16;
};

// Decodes JPEG or PNG bytes to 8-bit BGR or grey. Errors, never exceptions:
// InvalidArgument for empty, unknown, corrupt or unsupported bytes; ResourceExhausted over
// max_side. A JPEG whose data ends early decodes with the missing rows grey, as libjpeg
// (and imdecode) decode it.
StatusOr<cv::Mat> DecodeImageBytes(std::string_view bytes, const DecodeOptions& options);

// Baseline JPEG at `quality` (1..100), 4:2:0 for BGR, as cv::imencode(".jpg") writes it.
// REQUIRES: image is CV_8UC3 (BGR) or CV_8UC1, not empty.
StatusOr<std::string> EncodeJpeg(const cv::Mat& image, int quality);

// PNG of a CV_8UC3 (BGR) or CV_8UC1 image.
StatusOr<std::string> EncodePng(const cv::Mat& image);

}  // namespace sceneloc
