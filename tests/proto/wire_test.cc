// proto/wire: feature sets to the wire and back, and every malformed set refused.
#include "proto/wire.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace sceneloc {
namespace {

FeatureSet RandomFeatures(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0, 1);
  FeatureSet f;
  f.image_width = 640;
  f.image_height = 360;
  for (int i = 0; i < n; ++i) f.keypoints.push_back({u(rng) * 640, u(rng) * 360, 4, 90, 0.1f, 3});
  f.local.resize(n, kDescriptorSize);
  f.context.resize(n, kDescriptorSize);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < kDescriptorSize; ++j) {
      f.local(i, j) = u(rng);
      f.context(i, j) = u(rng);
    }
    f.local.row(i).normalize();
    f.context.row(i).normalize();
  }
  return f;
}

// float32 round-trips exactly; uint8 within quantisation and still unit-norm.
TEST(WireTest, RoundTripsBothEncodings) {
  const FeatureSet f = RandomFeatures(20, 1);
  v1::FeatureSet wire;
  EncodeFeatureSet(f, DescriptorEncoding::kFloat32, &wire);
  auto back = DecodeFeatureSet(wire, {});
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->local, f.local);
  EXPECT_EQ(back->context, f.context);
  EXPECT_EQ(back->keypoints[3].x, f.keypoints[3].x);
  EXPECT_EQ(back->keypoints[3].octave, 3);

  EncodeFeatureSet(f, DescriptorEncoding::kUint8, &wire);
  EXPECT_EQ(wire.local().uint8().size(), 20u * kDescriptorSize);
  auto quantised = DecodeFeatureSet(wire, {});
  ASSERT_TRUE(quantised.ok()) << quantised.status().ToString();
  EXPECT_LT((quantised->local - f.local).cwiseAbs().maxCoeff(), 0.01f);
  EXPECT_NEAR(quantised->context.row(7).norm(), 1.0f, 1e-5f);
}

// The keypoints of a serialised request counted from its bytes: as many as the parse
// finds, whatever comes before or after the feature set; 0 without one; at most as many
// as are there when the bytes are cut short or are not a request.
TEST(WireTest, CountsTheKeypointsOfARequestWithoutParsingIt) {
  v1::Request request;
  request.set_request_id(5);
  request.set_protocol(kProtocolVersion);
  request.mutable_localise()->set_map("m");
  request.mutable_localise()->set_session("s");
  EncodeFeatureSet(RandomFeatures(37, 2), DescriptorEncoding::kUint8,
                   request.mutable_localise()->mutable_features());
  std::string bytes = request.SerializeAsString();
  EXPECT_EQ(CountWireKeypoints(bytes.data(), bytes.size()), 37);
  for (const size_t cut : {size_t{0}, size_t{3}, bytes.size() / 2, bytes.size() - 1}) {
    const int64_t n = CountWireKeypoints(bytes.data(), cut);
    EXPECT_GE(n, 0) << cut;
    EXPECT_LE(n, 37) << cut;
  }
  for (int i = 0; i < 100'000; ++i) request.mutable_localise()->mutable_features()->add_keypoints();
  bytes = request.SerializeAsString();
  EXPECT_EQ(CountWireKeypoints(bytes.data(), bytes.size()), 100'037);

  v1::Request jpeg;
  jpeg.mutable_localise()->set_jpeg(std::string(1000, '\x1a'));
  bytes = jpeg.SerializeAsString();
  EXPECT_EQ(CountWireKeypoints(bytes.data(), bytes.size()), 0);
  v1::Request list;
  list.mutable_list_maps();
  bytes = list.SerializeAsString();
  EXPECT_EQ(CountWireKeypoints(bytes.data(), bytes.size()), 0);
  const std::string junk(4096, '\xff');
  EXPECT_EQ(CountWireKeypoints(junk.data(), junk.size()), 0);
  EXPECT_EQ(TooManyKeypoints(9000, 8192).code(), StatusCode::kResourceExhausted);
}

// Wrong lengths, both encodings, unnormalised or non-finite values, bad sizes and too
// many keypoints are each refused with their code.
TEST(WireTest, RefusesMalformedSets) {
  v1::FeatureSet good;
  EncodeFeatureSet(RandomFeatures(5, 2), DescriptorEncoding::kFloat32, &good);
  auto code = [](const v1::FeatureSet& w, FeatureSetLimits limits = {}) {
    return DecodeFeatureSet(w, limits).status().code();
  };
  v1::FeatureSet w = good;
  w.mutable_local()->mutable_float32()->Add(0.0f);
  EXPECT_EQ(code(w), StatusCode::kInvalidArgument);
  w = good;
  w.mutable_context()->set_uint8(std::string(5 * kDescriptorSize, '\1'));
  EXPECT_EQ(code(w), StatusCode::kInvalidArgument);  // both encodings
  w = good;
  w.mutable_local()->set_float32(0, 50.0f);
  EXPECT_EQ(code(w), StatusCode::kInvalidArgument);  // not unit-norm
  w = good;
  w.mutable_local()->set_float32(0, NAN);
  EXPECT_EQ(code(w), StatusCode::kInvalidArgument);
  w = good;
  w.mutable_keypoints(2)->set_angle(-INFINITY);
  EXPECT_EQ(code(w), StatusCode::kInvalidArgument);
  w = good;
  w.set_image_width(0);
  EXPECT_EQ(code(w), StatusCode::kInvalidArgument);
  w = good;
  w.set_image_height(100000);
  EXPECT_EQ(code(w), StatusCode::kResourceExhausted);
  EXPECT_EQ(code(good, {4, 8192}), StatusCode::kResourceExhausted);
  EXPECT_EQ(code(good), StatusCode::kOk);
  w = good;
  w.mutable_local()->clear_float32();
  EXPECT_EQ(code(w), StatusCode::kInvalidArgument);  // neither encoding
}

// Session names: 1..128 printable ASCII characters; anything else is refused saying why.
TEST(WireTest, SessionNames) {
  EXPECT_TRUE(CheckSessionName("robot-7").ok());
  EXPECT_TRUE(CheckSessionName("a b:c/d@e").ok());
  EXPECT_TRUE(CheckSessionName(std::string(128, 'x')).ok());
  EXPECT_NE(CheckSessionName("").message().find("empty"), std::string::npos);
  EXPECT_NE(CheckSessionName(std::string(129, 'x')).message().find("129"), std::string::npos);
  EXPECT_NE(CheckSessionName("a\nb").message().find("0x0a at offset 1"), std::string::npos);
  EXPECT_FALSE(CheckSessionName(std::string("a\0b", 3)).ok());
  EXPECT_FALSE(CheckSessionName("caf\xc3\xa9").ok());
}

}  // namespace
}  // namespace sceneloc
