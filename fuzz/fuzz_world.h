// What the fuzz targets and their seed generator share: a small real map and real JPEGs,
// made in code from the generated tour (common/synthetic/tour_generator.h), and the
// input layout of fuzz_map.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/map/map.h"
#include "common/util/status.h"

namespace sceneloc::fuzz {

struct FuzzWorld {
  Map map;                              // trained from the tour below, Finalize()d
  std::vector<std::string> tour_jpegs;  // the training pass, 320x240
  std::vector<std::string> test_jpegs;  // the test pass of the same route
};

// Renders a 6-location tour at 320x240 and trains a map from it (a few seconds). Errors:
// those of rendering and training, which mean a broken build.
StatusOr<FuzzWorld> MakeFuzzWorld();

// fuzz_map's input: one mode byte, then bytes.
//   mode & 1 == 0: the bytes are a whole map file, parsed as they are;
//   mode & 1 == 1: the bytes are a payload; the target puts a valid header in front
//                  (format version 1 when mode & 2, else 2; both CRCs right), so the
//                  fuzzer reaches the payload parser instead of stopping at a checksum.
inline constexpr uint8_t kMapModeWholeFile = 0;
inline constexpr uint8_t kMapModePayloadV2 = 1;
inline constexpr uint8_t kMapModePayloadV1 = 3;

// fuzz_session's input: one mode byte, then a session token (server/session_token.h).
//   mode & 1: the target makes the token's CRC right, so the fuzzer reaches its counts
//             and values instead of stopping at the checksum;
//   mode & 2: the map's filter keeps the speeds of kSessionFewTracked locations (the
//             compaction of sequence_filter.h), else of every location.
// The token belongs to session kSessionName of client kSessionClient on a map whose
// checksum is kSessionMapChecksum.
inline constexpr uint8_t kSessionModeFixCrc = 1;
inline constexpr uint8_t kSessionModeFewTracked = 2;
inline constexpr int kSessionFewTracked = 3;
inline constexpr char kSessionClient[] = "robot-key";
inline constexpr char kSessionName[] = "robot-1";
inline constexpr uint32_t kSessionMapChecksum = 0x5eed5eedu;

// A map file of `payload` with a valid header of `format_version`.
std::string WithHeader(const std::string& payload, uint32_t format_version);

}  // namespace sceneloc::fuzz
