#include "common/image/image_codec.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace sceneloc {
namespace {

// A textured colour frame of odd size (so that reduced sizes round), as a camera would see.
cv::Mat Scene(int width = 333, int height = 251) {
  cv::Mat image(height, width, CV_8UC3);
  cv::RNG rng(7);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(image, image, cv::Size(7, 7), 2.0);
  cv::rectangle(image, {40, 30}, {200, 120}, {20, 180, 240}, cv::FILLED);
  cv::circle(image, {250, 180}, 50, {200, 40, 90}, 5);
  return image;
}

std::string Bytes(const std::vector<uchar>& v) { return {v.begin(), v.end()}; }

std::string OpenCvEncode(const std::string& ext, const cv::Mat& image,
                         const std::vector<int>& params = {}) {
  std::vector<uchar> out;
  EXPECT_TRUE(cv::imencode(ext, image, out, params));
  return Bytes(out);
}

cv::Mat OpenCvDecode(const std::string& bytes, int flags) {
  const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data()));
  return cv::imdecode(buffer, flags);
}

bool Same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

double MaxDifference(const cv::Mat& a, const cv::Mat& b) {
  EXPECT_EQ(a.size(), b.size());
  EXPECT_EQ(a.type(), b.type());
  return a.size() == b.size() && a.type() == b.type() ? cv::norm(a, b, cv::NORM_INF) : 1e9;
}

cv::Mat Decode(const std::string& bytes, bool gray, int reduction = 1) {
  DecodeOptions options;
  options.gray = gray;
  options.reduction = reduction;
  auto image = DecodeImageBytes(bytes, options);
  EXPECT_TRUE(image.ok()) << image.status().message();
  return image.ok() ? *image : cv::Mat();
}

// An APP1 EXIF segment holding only IFD0's orientation tag, in either byte order, inserted
// after SOI.
std::string WithOrientation(const std::string& jpeg, int orientation, bool little_endian) {
  auto u16 = [&](uint16_t v) {
    return little_endian ? std::string{char(v & 0xFF), char(v >> 8)}
                         : std::string{char(v >> 8), char(v & 0xFF)};
  };
  auto u32 = [&](uint32_t v) {
    return little_endian ? u16(v & 0xFFFF) + u16(v >> 16) : u16(v >> 16) + u16(v & 0xFFFF);
  };
  std::string tiff = little_endian ? "II" : "MM";
  tiff += u16(42) + u32(8) + u16(1);                                  // IFD0 at 8, one entry
  tiff += u16(0x0112) + u16(3) + u32(1) + u16(orientation) + u16(0);  // orientation, SHORT
  tiff += u32(0);                                                     // no next IFD
  const std::string payload = std::string("Exif\0\0", 6) + tiff;
  const auto length = static_cast<uint16_t>(payload.size() + 2);
  const std::string segment =
      std::string{char(0xFF), char(0xE1), char(length >> 8), char(length & 0xFF)} + payload;
  return jpeg.substr(0, 2) + segment + jpeg.substr(2);
}

TEST(ImageCodecTest, JpegDecodesAsImdecodeDoes) {
  const std::string jpeg = OpenCvEncode(".jpg", Scene(), {cv::IMWRITE_JPEG_QUALITY, 90});
  EXPECT_TRUE(Same(Decode(jpeg, false), OpenCvDecode(jpeg, cv::IMREAD_COLOR)));
  EXPECT_TRUE(Same(Decode(jpeg, true), OpenCvDecode(jpeg, cv::IMREAD_GRAYSCALE)));
  EXPECT_TRUE(Same(Decode(jpeg, true, 2), OpenCvDecode(jpeg, cv::IMREAD_REDUCED_GRAYSCALE_2)));
  EXPECT_TRUE(Same(Decode(jpeg, true, 4), OpenCvDecode(jpeg, cv::IMREAD_REDUCED_GRAYSCALE_4)));
  EXPECT_TRUE(Same(Decode(jpeg, true, 8), OpenCvDecode(jpeg, cv::IMREAD_REDUCED_GRAYSCALE_8)));
  EXPECT_TRUE(Same(Decode(jpeg, false, 2), OpenCvDecode(jpeg, cv::IMREAD_REDUCED_COLOR_2)));
  EXPECT_EQ(Decode(jpeg, true, 2).size(), cv::Size(167, 126));  // rounded up, as libjpeg does
}

TEST(ImageCodecTest, AGreyJpegDecodesAsImdecodeDoes) {
  cv::Mat gray;
  cv::cvtColor(Scene(), gray, cv::COLOR_BGR2GRAY);
  const std::string jpeg = OpenCvEncode(".jpg", gray);
  EXPECT_TRUE(Same(Decode(jpeg, false), OpenCvDecode(jpeg, cv::IMREAD_COLOR)));
  EXPECT_TRUE(Same(Decode(jpeg, true, 4), OpenCvDecode(jpeg, cv::IMREAD_REDUCED_GRAYSCALE_4)));
}

TEST(ImageCodecTest, EveryExifOrientationTurnsTheImageAsImdecodeDoes) {
  const std::string plain = OpenCvEncode(".jpg", Scene(), {cv::IMWRITE_JPEG_QUALITY, 85});
  for (int orientation = 1; orientation <= 8; ++orientation) {
    for (bool little : {true, false}) {
      SCOPED_TRACE("orientation " + std::to_string(orientation) + (little ? " II" : " MM"));
      const std::string jpeg = WithOrientation(plain, orientation, little);
      const cv::Mat colour = Decode(jpeg, false);
      EXPECT_TRUE(Same(colour, OpenCvDecode(jpeg, cv::IMREAD_COLOR)));
      EXPECT_TRUE(Same(Decode(jpeg, true, 2), OpenCvDecode(jpeg, cv::IMREAD_REDUCED_GRAYSCALE_2)));
      EXPECT_EQ(colour.cols == 333, orientation <= 4);  // 5..8 swap the sides
    }
  }
}

TEST(ImageCodecTest, AJpegCutShortKeepsItsRowsAndGreysTheRest) {
  const std::string jpeg = OpenCvEncode(".jpg", Scene());
  const std::string cut = jpeg.substr(0, jpeg.size() * 2 / 3);
  const cv::Mat ours = Decode(cut, true);
  ASSERT_EQ(ours.size(), cv::Size(333, 251));
  // The rows the bytes hold are imdecode's; past them libjpeg decodes zero coefficients
  // (grey 128). imdecode's source manager suspends there and leaves those rows as they were
  // allocated, so they are compared with nothing.
  const cv::Mat reference = OpenCvDecode(cut, cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(reference.empty());
  EXPECT_TRUE(Same(ours.rowRange(0, 144), reference.rowRange(0, 144)));
  EXPECT_EQ(cv::countNonZero(ours.row(250) != 128), 0);
}

TEST(ImageCodecTest, EncodeJpegWritesWhatImencodeWrites) {
  const cv::Mat scene = Scene();
  for (int quality : {50, 90, 95}) {
    auto ours = EncodeJpeg(scene, quality);
    ASSERT_TRUE(ours.ok()) << ours.status().message();
    const std::string theirs = OpenCvEncode(".jpg", scene, {cv::IMWRITE_JPEG_QUALITY, quality});
    // The same library with the same settings: the same pixels, and here the same bytes.
    EXPECT_TRUE(Same(OpenCvDecode(*ours, cv::IMREAD_COLOR), OpenCvDecode(theirs, cv::IMREAD_COLOR)))
        << "quality " << quality;
    EXPECT_EQ(*ours, theirs) << "quality " << quality;
  }
  cv::Mat gray;
  cv::cvtColor(scene, gray, cv::COLOR_BGR2GRAY);
  auto ours = EncodeJpeg(gray, 90);
  ASSERT_TRUE(ours.ok());
  EXPECT_EQ(OpenCvDecode(*ours, cv::IMREAD_UNCHANGED).channels(), 1);
}

TEST(ImageCodecTest, PngDecodesAsImdecodeDoes) {
  const cv::Mat scene = Scene();
  const std::string png = OpenCvEncode(".png", scene);
  EXPECT_TRUE(Same(Decode(png, false), scene));
  EXPECT_TRUE(Same(Decode(png, false, 2), OpenCvDecode(png, cv::IMREAD_REDUCED_COLOR_2)));
  // Grey from colour: OpenCV asks libpng for its own fixed-point conversion; the codec uses
  // cvtColor's coefficients, the same up to rounding.
  EXPECT_LE(MaxDifference(Decode(png, true), OpenCvDecode(png, cv::IMREAD_GRAYSCALE)), 1);

  cv::Mat gray;
  cv::cvtColor(scene, gray, cv::COLOR_BGR2GRAY);
  const std::string gray_png = OpenCvEncode(".png", gray);
  EXPECT_TRUE(Same(Decode(gray_png, true), gray));
  EXPECT_TRUE(Same(Decode(gray_png, false), OpenCvDecode(gray_png, cv::IMREAD_COLOR)));

  cv::Mat bgra;
  cv::cvtColor(scene, bgra, cv::COLOR_BGR2BGRA);
  bgra.forEach<cv::Vec4b>([](cv::Vec4b& p, const int* at) { p[3] = uchar(at[1] % 256); });
  const std::string alpha_png = OpenCvEncode(".png", bgra);
  EXPECT_TRUE(Same(Decode(alpha_png, false), OpenCvDecode(alpha_png, cv::IMREAD_COLOR)));

  cv::Mat wide;
  scene.convertTo(wide, CV_16UC3, 257.0);
  wide += cv::Scalar::all(100);  // low bytes that must not round the high ones up
  const std::string wide_png = OpenCvEncode(".png", wide);
  EXPECT_TRUE(Same(Decode(wide_png, false), OpenCvDecode(wide_png, cv::IMREAD_COLOR)));
}

TEST(ImageCodecTest, EncodePngRoundTrips) {
  const cv::Mat scene = Scene();
  auto png = EncodePng(scene);
  ASSERT_TRUE(png.ok()) << png.status().message();
  EXPECT_EQ(SniffImageFormat(*png), ImageFormat::kPng);
  EXPECT_TRUE(Same(OpenCvDecode(*png, cv::IMREAD_UNCHANGED), scene));
  cv::Mat gray;
  cv::cvtColor(scene, gray, cv::COLOR_BGR2GRAY);
  png = EncodePng(gray);
  ASSERT_TRUE(png.ok());
  EXPECT_TRUE(Same(Decode(*png, true), gray));
  // A view into a larger image: rows with a stride.
  png = EncodePng(scene(cv::Rect(10, 20, 100, 50)));
  ASSERT_TRUE(png.ok());
  EXPECT_TRUE(Same(Decode(*png, false), scene(cv::Rect(10, 20, 100, 50))));
}

TEST(ImageCodecTest, BadBytesAreErrorsThatSayWhat) {
  DecodeOptions options;
  auto empty = DecodeImageBytes("", options);
  ASSERT_FALSE(empty.ok());
  EXPECT_EQ(empty.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(empty.status().message().find("empty"), std::string::npos);

  auto text = DecodeImageBytes("GIF89a not an image we read", options);
  ASSERT_FALSE(text.ok());
  EXPECT_NE(text.status().message().find("not a decodable JPEG or PNG"), std::string::npos);

  const std::string jpeg = OpenCvEncode(".jpg", Scene());
  auto header_only = DecodeImageBytes(jpeg.substr(0, 40), options);
  ASSERT_FALSE(header_only.ok());
  EXPECT_EQ(header_only.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(header_only.status().message().find("JPEG"), std::string::npos);

  const std::string png = OpenCvEncode(".png", Scene());
  auto png_cut = DecodeImageBytes(png.substr(0, png.size() / 2), options);
  ASSERT_FALSE(png_cut.ok());
  EXPECT_NE(png_cut.status().message().find("PNG"), std::string::npos);

  options.reduction = 3;
  auto three = DecodeImageBytes(jpeg, options);
  ASSERT_FALSE(three.ok());
  EXPECT_NE(three.status().message().find("1, 2, 4 or 8"), std::string::npos);
}

TEST(ImageCodecTest, AnImageOverTheSideLimitIsRefusedAtItsDecodedSize) {
  const std::string jpeg = OpenCvEncode(".jpg", Scene());  // 333x251
  const std::string png = OpenCvEncode(".png", Scene());
  for (const std::string& bytes : {jpeg, png}) {
    DecodeOptions options;
    options.max_side = 300;
    auto full = DecodeImageBytes(bytes, options);
    ASSERT_FALSE(full.ok());
    EXPECT_EQ(full.status().code(), StatusCode::kResourceExhausted);
    EXPECT_NE(full.status().message().find("333x251"), std::string::npos)
        << full.status().message();
    options.reduction = 2;  // 167x126 (JPEG) or 166x125 (PNG): within the limit
    EXPECT_TRUE(DecodeImageBytes(bytes, options).ok());
  }
}

TEST(ImageCodecTest, EncodingRefusesWhatItCannotWrite) {
  EXPECT_FALSE(EncodeJpeg(cv::Mat(), 90).ok());
  EXPECT_FALSE(EncodeJpeg(cv::Mat(10, 10, CV_32FC1, cv::Scalar(0)), 90).ok());
  EXPECT_FALSE(EncodeJpeg(Scene(), 0).ok());
  EXPECT_FALSE(EncodeJpeg(Scene(), 101).ok());
  EXPECT_FALSE(EncodePng(cv::Mat(10, 10, CV_8UC4, cv::Scalar::all(0))).ok());
}

}  // namespace
}  // namespace sceneloc
