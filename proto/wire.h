// Conversions between the wire messages (proto/sceneloc.proto) and the engine's types,
// shared by the server and the client. Decoding treats its input as untrusted: every
// count, length and number is checked before anything is allocated from it.
//
// Thread-safe: free functions without shared state.
#pragma once

#include <cstddef>
#include <cstdint>

#include "common/features/feature_set.h"
#include "common/util/status.h"
#include "proto/sceneloc.pb.h"

namespace sceneloc {

// Caps on a feature set from the network.
struct FeatureSetLimits {
  // Most keypoints a feature set may carry (the extractor's default cap is 1000).
  int max_keypoints = 8192;
  // Largest image width or height a feature set may claim, pixels.
  int max_image_side = kDefaultMaxImageSide;

  Status Validate() const;
};

// How descriptors travel. float32 is exact; uint8 is a quarter of the size and loses
// ~0.2% of a descriptor's norm to rounding.
enum class DescriptorEncoding { kFloat32, kUint8 };

// Writes `features` into `out` (replacing its content). uint8 stores round(512 * v)
// clamped to 255 per value, OpenCV's SIFT scale for unit descriptors.
void EncodeFeatureSet(const FeatureSet& features, DescriptorEncoding encoding, v1::FeatureSet* out);

// Reads a feature set from the wire. Errors: InvalidArgument for a wrong descriptor
// length, both or neither encoding set, a float32 row that is not unit-norm (or zero), a
// non-finite number, a bad image size; ResourceExhausted for more keypoints or a larger
// image than `limits` allow. uint8 rows are L2-normalised; float32 rows are used as sent.
StatusOr<FeatureSet> DecodeFeatureSet(const v1::FeatureSet& wire, const FeatureSetLimits& limits);

// The keypoints of a serialised Request's feature set (Request.localise.features.
// keypoints), counted from the wire format without parsing it: a request of millions of
// empty keypoints is a few bytes each to send and a message each to parse, so the server
// counts them (one pass over the bytes, nothing allocated) before it parses. Counts up to the
// end of the feature set or the first malformed byte (the parse then says what is wrong);
// 0 for a request without a feature set. Sizes over 2 GiB, which no request reaches, give 0.
int64_t CountWireKeypoints(const void* data, size_t size);

// The error DecodeFeatureSet gives a feature set of `keypoints` keypoints, more than
// `max_keypoints`.
Status TooManyKeypoints(int64_t keypoints, int max_keypoints);

// The wire status for an engine status code (kOk -> OK).
v1::StatusCode ToWireCode(StatusCode code);

// Whether a session name (LocaliseRequest.session) is one a client may use:
// 1..kMaxSessionName printable ASCII characters. InvalidArgument saying why otherwise.
inline constexpr size_t kMaxSessionName = 128;

// The wire protocol's version (Request.protocol, Reply.protocol): 1 for sceneloc.v1. Only
// a change that old peers cannot read raises it; added fields do not.
inline constexpr uint32_t kProtocolVersion = 1;
Status CheckSessionName(const std::string& name);

}  // namespace sceneloc
