// libFuzzer target: the bytes of one request as the server reads them off the socket.
// Covers the Request parse and everything the server checks before any engine work:
// the feature-set conversion (proto/wire.h), the JPEG header and scan count
// (server/jpeg_header.h) and the map-name check of a reload. Fast (no map, no decoding),
// so it explores the decoders deeply; fuzz_handler runs the same inputs end to end.
//
// Oracles beyond the sanitizers: a feature set that decodes re-encodes (float32) to one
// that decodes to the same keypoints and values; a JPEG whose header reads has a size
// within what it claims.
#include <cstdlib>
#include <string>

#include "proto/sceneloc.pb.h"
#include "proto/wire.h"
#include "server/jpeg_header.h"
#include "server/request_handler.h"

namespace sceneloc {
namespace {

void CheckFeatures(const v1::FeatureSet& wire) {
  const FeatureSetLimits limits;
  auto decoded = DecodeFeatureSet(wire, limits);
  if (!decoded.ok()) return;
  v1::FeatureSet again;
  EncodeFeatureSet(*decoded, DescriptorEncoding::kFloat32, &again);
  auto round_trip = DecodeFeatureSet(again, limits);
  if (!round_trip.ok() || round_trip->size() != decoded->size() ||
      round_trip->local != decoded->local || round_trip->context != decoded->context ||
      round_trip->holistic != decoded->holistic) {
    std::abort();  // what was accepted once must be accepted again, unchanged
  }
}

void CheckJpeg(const std::string& jpeg) {
  auto dims = ReadJpegDimensions(jpeg);
  if (dims.ok() && (dims->width <= 0 || dims->height <= 0)) std::abort();
  if (CountJpegScans(jpeg) < 0) std::abort();
}

}  // namespace
}  // namespace sceneloc

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace sceneloc;
  // The count before parsing reads any bytes (ASan/UBSan watch it); of a request as
  // serialised it is exactly what the parse finds.
  (void)CountWireKeypoints(data, size);
  v1::Request request;
  if (!request.ParseFromArray(data, static_cast<int>(size))) return 0;
  if (request.kind_case() == v1::Request::kLocalise && request.localise().has_features()) {
    const std::string canonical = request.SerializeAsString();
    if (CountWireKeypoints(canonical.data(), canonical.size()) !=
        request.localise().features().keypoints_size()) {
      std::abort();
    }
  }
  switch (request.kind_case()) {
    case v1::Request::kLocalise:
      if (request.localise().has_features()) CheckFeatures(request.localise().features());
      if (request.localise().has_jpeg()) CheckJpeg(request.localise().jpeg());
      break;
    case v1::Request::kReloadMap:
      (void)RequestHandler::CheckReload(request.reload_map());
      break;
    default:
      break;
  }
  return 0;
}
