#include "proto/wire.h"

#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/wire_format_lite.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace sceneloc {
namespace {

// A unit descriptor from the extractor has norm 1 within float rounding; a row scaled
// by mistake (e.g. raw 0..255 floats) is far off.
constexpr float kNormTolerance = 0.01f;

void EncodeMatrix(const DescriptorMatrix& m, DescriptorEncoding encoding,
                  v1::DescriptorMatrix* out) {
  out->Clear();
  const size_t n = static_cast<size_t>(m.size());
  if (encoding == DescriptorEncoding::kFloat32) {
    out->mutable_float32()->Add(m.data(), m.data() + n);
    return;
  }
  std::string* bytes = out->mutable_uint8();
  bytes->resize(n);
  for (size_t i = 0; i < n; ++i) {
    const float v = std::clamp(std::round(512.0f * m.data()[i]), 0.0f, 255.0f);
    (*bytes)[i] = static_cast<char>(static_cast<uint8_t>(v));
  }
}

Status CheckUnitRows(const DescriptorMatrix& m, const char* which) {
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    const float norm = m.row(i).norm();
    if (norm != 0.0f && std::abs(norm - 1.0f) > kNormTolerance) {
      return InvalidArgument(std::string(which) + " descriptor " + std::to_string(i) +
                             " has norm " + std::to_string(norm) +
                             "; float32 descriptors must be L2-normalised");
    }
  }
  return Status::Ok();
}

// Fills `out` (n rows) from either encoding; the length is checked first.
Status DecodeMatrix(const v1::DescriptorMatrix& wire, int n, const char* which,
                    DescriptorMatrix* out) {
  const size_t want = static_cast<size_t>(n) * kDescriptorSize;
  const size_t floats = static_cast<size_t>(wire.float32_size());
  const size_t bytes = wire.uint8().size();
  if (floats != 0 && bytes != 0) {
    return InvalidArgument(std::string(which) + " descriptors are set as both float32 and uint8");
  }
  const size_t got = floats != 0 ? floats : bytes;
  if (got != want) {
    return InvalidArgument(std::string(which) + " descriptors hold " + std::to_string(got) +
                           " values; " + std::to_string(n) + " keypoints need " +
                           std::to_string(want) + " (128 each)");
  }
  out->resize(n, kDescriptorSize);
  if (floats != 0) {
    std::copy(wire.float32().begin(), wire.float32().end(), out->data());
    return Status::Ok();
  }
  const auto* raw = reinterpret_cast<const uint8_t*>(wire.uint8().data());
  for (size_t i = 0; i < want; ++i) out->data()[i] = static_cast<float>(raw[i]);
  NormaliseRows(out);
  return Status::Ok();
}

// The holistic descriptor, if any: grid sizes in range and values for exactly the grid.
Status DecodeHolistic(const v1::Holistic& wire, FeatureSet* out) {
  if (wire.cols() == 0 && wire.rows() == 0 && wire.bins() == 0 && wire.values_size() == 0) {
    return Status::Ok();
  }
  if (wire.cols() < 1 || wire.cols() > kMaxHolisticCols || wire.rows() < 1 ||
      wire.rows() > kMaxHolisticRows || wire.bins() < 1 || wire.bins() > kMaxHolisticBins) {
    return InvalidArgument("holistic grid " + std::to_string(wire.cols()) + "x" +
                           std::to_string(wire.rows()) + "x" + std::to_string(wire.bins()) +
                           " is out of range");
  }
  out->holistic_grid = {wire.cols(), wire.rows(), wire.bins()};
  if (wire.values_size() != out->holistic_grid.size()) {
    return InvalidArgument("holistic descriptor holds " + std::to_string(wire.values_size()) +
                           " values; its grid needs " + std::to_string(out->holistic_grid.size()));
  }
  out->holistic.assign(wire.values().begin(), wire.values().end());
  return Status::Ok();
}

}  // namespace

Status FeatureSetLimits::Validate() const {
  if (max_keypoints < 1) return InvalidArgument("max_keypoints must be >= 1");
  if (max_image_side < kMinImageSide || max_image_side > kMaxImageSideSetting) {
    return InvalidArgument("max_image_side must be in [" + std::to_string(kMinImageSide) + ", " +
                           std::to_string(kMaxImageSideSetting) + "]");
  }
  return Status::Ok();
}

void EncodeFeatureSet(const FeatureSet& features, DescriptorEncoding encoding,
                      v1::FeatureSet* out) {
  out->Clear();
  out->set_image_width(features.image_width);
  out->set_image_height(features.image_height);
  out->mutable_keypoints()->Reserve(features.size());
  for (const Keypoint& k : features.keypoints) {
    v1::Keypoint* w = out->add_keypoints();
    w->set_x(k.x);
    w->set_y(k.y);
    w->set_size(k.size);
    w->set_angle(k.angle);
    w->set_response(k.response);
    w->set_octave(k.octave);
  }
  EncodeMatrix(features.local, encoding, out->mutable_local());
  EncodeMatrix(features.context, encoding, out->mutable_context());
  if (!features.holistic.empty()) {
    v1::Holistic* h = out->mutable_holistic();
    h->set_cols(features.holistic_grid.cols);
    h->set_rows(features.holistic_grid.rows);
    h->set_bins(features.holistic_grid.bins);
    h->mutable_values()->Add(features.holistic.begin(), features.holistic.end());
  }
}

Status TooManyKeypoints(int64_t keypoints, int max_keypoints) {
  return ResourceExhausted("feature set has " + std::to_string(keypoints) + " keypoints; at most " +
                           std::to_string(max_keypoints) + " are accepted");
}

namespace {

using google::protobuf::internal::WireFormatLite;

// Inside the message `in` is positioned in (up to its limit): the length-delimited field
// `field`, to whose body `in` is then limited; false when there is none or the bytes are
// malformed. The limits are never popped: the stream is read no further than the set.
bool EnterField(google::protobuf::io::CodedInputStream* in, int field) {
  while (const uint32_t tag = in->ReadTag()) {
    if (WireFormatLite::GetTagFieldNumber(tag) == field &&
        WireFormatLite::GetTagWireType(tag) == WireFormatLite::WIRETYPE_LENGTH_DELIMITED) {
      uint32_t length = 0;
      if (!in->ReadVarint32(&length)) return false;
      in->PushLimit(static_cast<int>(length));
      return true;
    }
    if (!WireFormatLite::SkipField(in, tag)) return false;
  }
  return false;
}

}  // namespace

int64_t CountWireKeypoints(const void* data, size_t size) {
  if (size > static_cast<size_t>(std::numeric_limits<int>::max())) return 0;
  google::protobuf::io::CodedInputStream in(static_cast<const uint8_t*>(data),
                                            static_cast<int>(size));
  // Request.localise (2), then LocaliseRequest.features (4). A field sent twice is merged
  // by the parser; the count here stops at the first, so the parse's check still applies.
  if (!EnterField(&in, 2) || !EnterField(&in, 4)) return 0;
  int64_t keypoints = 0;
  while (const uint32_t tag = in.ReadTag()) {
    if (WireFormatLite::GetTagFieldNumber(tag) == 3 &&
        WireFormatLite::GetTagWireType(tag) == WireFormatLite::WIRETYPE_LENGTH_DELIMITED) {
      ++keypoints;  // FeatureSet.keypoints
    }
    if (!WireFormatLite::SkipField(&in, tag)) break;
  }
  return keypoints;
}

StatusOr<FeatureSet> DecodeFeatureSet(const v1::FeatureSet& wire, const FeatureSetLimits& limits) {
  const int n = wire.keypoints_size();
  if (n > limits.max_keypoints) return TooManyKeypoints(n, limits.max_keypoints);
  if (wire.image_width() <= 0 || wire.image_height() <= 0) {
    return InvalidArgument("feature set image size must be positive");
  }
  if (wire.image_width() > limits.max_image_side || wire.image_height() > limits.max_image_side) {
    return ResourceExhausted("feature set image is larger than " +
                             std::to_string(limits.max_image_side) + " pixels per side");
  }
  FeatureSet f;
  f.image_width = wire.image_width();
  f.image_height = wire.image_height();
  f.keypoints.resize(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const v1::Keypoint& k = wire.keypoints(i);
    f.keypoints[static_cast<size_t>(i)] = {k.x(),     k.y(),        k.size(),
                                           k.angle(), k.response(), k.octave()};
  }
  SCENELOC_RETURN_IF_ERROR(DecodeMatrix(wire.local(), n, "local", &f.local));
  SCENELOC_RETURN_IF_ERROR(DecodeMatrix(wire.context(), n, "context", &f.context));
  SCENELOC_RETURN_IF_ERROR(DecodeHolistic(wire.holistic(), &f));
  SCENELOC_RETURN_IF_ERROR(ValidateFeatureSet(f));
  if (wire.local().float32_size() != 0) SCENELOC_RETURN_IF_ERROR(CheckUnitRows(f.local, "local"));
  if (wire.context().float32_size() != 0) {
    SCENELOC_RETURN_IF_ERROR(CheckUnitRows(f.context, "context"));
  }
  return f;
}

v1::StatusCode ToWireCode(StatusCode code) {
  switch (code) {
    case StatusCode::kOk:
      return v1::OK;
    case StatusCode::kInvalidArgument:
      return v1::INVALID_ARGUMENT;
    case StatusCode::kNotFound:
      return v1::NOT_FOUND;
    case StatusCode::kDataLoss:
      return v1::DATA_LOSS;
    case StatusCode::kFailedPrecondition:
      return v1::FAILED_PRECONDITION;
    case StatusCode::kUnimplemented:
      return v1::UNIMPLEMENTED;
    case StatusCode::kDeadlineExceeded:
      return v1::DEADLINE_EXCEEDED;
    case StatusCode::kPermissionDenied:
      return v1::PERMISSION_DENIED;
    case StatusCode::kResourceExhausted:
      return v1::RESOURCE_EXHAUSTED;
    case StatusCode::kInternal:
    case StatusCode::kIoError:
      return v1::INTERNAL;
  }
  return v1::INTERNAL;
}

Status CheckSessionName(const std::string& name) {
  if (name.empty()) return InvalidArgument("session name is empty");
  if (name.size() > kMaxSessionName) {
    return InvalidArgument("session name is " + std::to_string(name.size()) + " bytes; at most " +
                           std::to_string(kMaxSessionName));
  }
  for (size_t i = 0; i < name.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(name[i]);
    if (c < 0x20 || c > 0x7e) {
      return InvalidArgument("session name holds a byte that is not printable ASCII (0x" +
                             std::string(1, "0123456789abcdef"[c >> 4]) +
                             std::string(1, "0123456789abcdef"[c & 15]) + " at offset " +
                             std::to_string(i) + ")");
    }
  }
  return Status::Ok();
}

}  // namespace sceneloc
