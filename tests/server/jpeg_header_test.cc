// ReadJpegDimensions: real encoder output, and every way a header can be cut or bent.
#include "server/jpeg_header.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <random>

namespace sceneloc {
namespace {

std::string Encode(int width, int height, int channels, bool progressive = false) {
  cv::Mat image(height, width, channels == 1 ? CV_8UC1 : CV_8UC3, cv::Scalar::all(90));
  cv::randu(image, 0, 255);
  std::vector<uchar> bytes;
  cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_PROGRESSIVE, progressive ? 1 : 0});
  return std::string(bytes.begin(), bytes.end());
}

// Baseline and progressive, grey and colour JPEGs from OpenCV report their true size.
TEST(JpegHeaderTest, ReadsTheSizeOfEncodedImages) {
  for (const bool progressive : {false, true}) {
    auto d = ReadJpegDimensions(Encode(123, 45, 3, progressive));
    ASSERT_TRUE(d.ok()) << d.status().ToString();
    EXPECT_EQ(d->width, 123);
    EXPECT_EQ(d->height, 45);
    EXPECT_EQ(d->components, 3);
    EXPECT_EQ(d->progressive, progressive);
  }
  auto grey = ReadJpegDimensions(Encode(64, 80, 1));
  ASSERT_TRUE(grey.ok());
  EXPECT_EQ(grey->components, 1);
}

// Not a JPEG, cut before the frame header, or an empty buffer: InvalidArgument.
TEST(JpegHeaderTest, RefusesNonJpegAndTruncatedHeaders) {
  const std::string jpeg = Encode(100, 100, 3);
  const size_t sof = jpeg.find("\xff\xc0");
  ASSERT_NE(sof, std::string::npos);
  for (size_t cut : {size_t{0}, size_t{1}, size_t{2}, size_t{3}, sof, sof + 4}) {
    EXPECT_EQ(ReadJpegDimensions(jpeg.substr(0, cut)).status().code(), StatusCode::kInvalidArgument)
        << "cut at " << cut;
  }
  EXPECT_FALSE(ReadJpegDimensions("\x89PNG\r\n\x1a\n....").ok());
  std::string zero = jpeg;
  zero[sof + 5] = zero[sof + 6] = 0;  // height 0 (defined later by DNL): refused
  EXPECT_FALSE(ReadJpegDimensions(zero).ok());
}

// A frame header hidden where libjpeg resynchronises: 0xFF00 is garbage to libjpeg, which
// searches on and finds the large JPEG inside; a parser that skipped "marker 0x00" by its
// "length" would see only the small frame after it and let the large image through. The
// header check must refuse what it cannot read the way the decoder does (the fuzz_jpeg
// oracle found this).
TEST(JpegHeaderTest, RefusesAFrameHiddenFromTheHeaderCheck) {
  cv::Mat flat(150, 200, CV_8UC1, cv::Scalar(90));
  std::vector<uchar> encoded;
  cv::imencode(".jpg", flat, encoded);
  const std::string large(encoded.begin(), encoded.end());
  const std::string small = Encode(40, 30, 1);
  const size_t hidden = large.size() - 2 + 2;  // the large JPEG after its SOI, plus the length
  ASSERT_LT(hidden, 0xFF00u);
  std::string smuggled = "\xff\xd8\xff";
  smuggled += '\0';
  smuggled += static_cast<char>(hidden >> 8);
  smuggled += static_cast<char>(hidden & 0xFF);
  smuggled += large.substr(2) + small.substr(2);

  // The decoder reads the large frame (that is the danger), and the check refuses.
  const cv::Mat decoded =
      cv::imdecode(std::vector<uchar>(smuggled.begin(), smuggled.end()), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(decoded.empty());
  EXPECT_EQ(decoded.cols, 200);
  auto d = ReadJpegDimensions(smuggled);
  ASSERT_FALSE(d.ok()) << "read " << d->width << "x" << d->height;
  EXPECT_EQ(d.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(d.status().message().find("marker 0x00"), std::string::npos) << d.status().ToString();

  // Every marker libjpeg does not read as a header segment is refused in the same place; the
  // ones it does read (an APP segment here) are skipped by their length as before.
  for (int marker = 0x00; marker < 0xFF; ++marker) {
    const bool segment = (marker >= 0xC0 && marker <= 0xCF) || marker == 0xDB || marker == 0xDC ||
                         marker == 0xDD || (marker >= 0xE0 && marker <= 0xEF) || marker == 0xFE;
    const bool standalone = marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7);
    if (segment || standalone || marker == 0xD9 || marker == 0xDA) continue;
    std::string bytes = "\xff\xd8\xff";
    bytes += static_cast<char>(marker);
    bytes += std::string(
                 "\x00\x04"
                 "ab",
                 4) +
             small.substr(2);
    EXPECT_FALSE(ReadJpegDimensions(bytes).ok()) << "marker " << marker;
  }
  std::string with_app = "\xff\xd8\xff\xe5";
  with_app += std::string(
                  "\x00\x04"
                  "ab",
                  4) +
              small.substr(2);
  auto app = ReadJpegDimensions(with_app);
  ASSERT_TRUE(app.ok()) << app.status().ToString();
  EXPECT_EQ(app->width, 40);
}

// Random bytes after a JPEG start marker never read out of bounds (run under ASAN) and
// never report a zero size.
TEST(JpegHeaderTest, RandomBytesAreSafe) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 2000; ++trial) {
    std::string bytes = "\xff\xd8";
    const size_t n = rng() % 64;
    for (size_t i = 0; i < n; ++i)
      bytes.push_back(static_cast<char>(rng() % 4 == 0 ? 0xFF : rng()));
    EXPECT_GE(CountJpegScans(bytes), 0);
    auto d = ReadJpegDimensions(bytes);
    if (d.ok()) {
      EXPECT_GT(d->width * d->height, 0);
    }
  }
}

// A JPEG with `extra` more copies of its last scan (segment and entropy-coded data)
// before the end-of-image marker: how a decompression bomb is made.
std::string WithExtraScans(const std::string& jpeg, int extra) {
  const size_t last_sos = jpeg.rfind("\xff\xda");
  const size_t eoi = jpeg.rfind("\xff\xd9");
  EXPECT_NE(last_sos, std::string::npos);
  EXPECT_EQ(eoi, jpeg.size() - 2);
  const std::string scan = jpeg.substr(last_sos, eoi - last_sos);
  std::string out = jpeg.substr(0, eoi);
  for (int i = 0; i < extra; ++i) out += scan;
  return out + "\xff\xd9";
}

// Baseline JPEGs have one scan, progressive ones several; scans appended are counted, and
// the entropy-coded data between them (with its 0xFF00 stuffing and restart markers) is
// not mistaken for markers.
TEST(JpegHeaderTest, CountsScans) {
  EXPECT_EQ(CountJpegScans(Encode(200, 120, 3)), 1);
  EXPECT_EQ(CountJpegScans(Encode(200, 120, 1)), 1);
  const std::string progressive = Encode(200, 120, 3, /*progressive=*/true);
  const int scans = CountJpegScans(progressive);
  EXPECT_GT(scans, 1);
  EXPECT_LE(scans, 20);
  EXPECT_EQ(CountJpegScans(WithExtraScans(progressive, 1500)), scans + 1500);
  EXPECT_EQ(CountJpegScans(""), 0);
  EXPECT_EQ(CountJpegScans("\xff\xd8"), 0);
}

// The decoding memory estimate: 3 bytes a pixel, plus the coefficients of a progressive
// JPEG (2 bytes a pixel per component).
TEST(JpegHeaderTest, EstimatesDecodingMemory) {
  EXPECT_EQ(EstimateDecodeBytes(*ReadJpegDimensions(Encode(100, 50, 3))), 100 * 50 * 3);
  EXPECT_EQ(EstimateDecodeBytes(*ReadJpegDimensions(Encode(100, 50, 3, true))),
            100 * 50 * 3 + 100 * 50 * 2 * 3);
  EXPECT_EQ(EstimateDecodeBytes(*ReadJpegDimensions(Encode(100, 50, 1, true))),
            100 * 50 * 3 + 100 * 50 * 2);
  JpegDimensions largest{65535, 65535, 3, true};
  EXPECT_EQ(EstimateDecodeBytes(largest), int64_t{65535} * 65535 * 9);  // no overflow
}

}  // namespace
}  // namespace sceneloc
