// A session's filter state as bytes (proto SessionAnswer.state, LocaliseRequest.session_state):
// what lets the next frame of a session be answered by another server process (a fleet
// behind one address) or by this one after it forgot the session (restart,
// eviction, expiry). The client sends back the state of its last reply; sceneloc::Client
// does it by itself.
//
// Layout (little-endian): "SLS6", uint32 map key (Map::PlacesKey: the map's tour and places,
// the same in every process serving that map and in every version of it that keeps its places,
// such as one extended by a walk of its route), uint32 locations N, uint32 speeds S (the filter's
// num_speeds()), uint32 tracked locations K, uint32 frames, uint32 camera bins B (0 before
// the session has measured its camera's scale, else SequenceOptions::kCameraBins), uint64
// session hash (FNV-1a of the client's key name and the session name), float32 the track's
// support, then the SequenceState: N + 1 float32 location, K uint32 tracked, (K + 1) S
// float32 speeds, B uint16 camera counts; uint32 CRC-32 of everything before it.
// 44 + 4 (N + 1 + K + (K + 1) S) + 2 B bytes: 5,652 at 200 locations, 17 speeds, 64 tracked
// and the camera measured; 44,852 at 10,000. A "SLS5" token (the same without the support)
// continues with a fresh support. A well-formed token of an earlier format
// ("SLS1": N + 1 values; "SLS2": 2N + 1, the direction of travel; "SLS3": S N + 1, every
// location's speeds; "SLS4": no camera) or of other filter settings (another S) starts the
// session again, as another map's does; one with another number of tracked locations
// continues (the next frame compacts it to this server's).
//
// The bytes come from the client: untrusted. ParseSessionToken checks size, checksum,
// finite non-negative belief with a positive sum, and which session it belongs to.
// Nothing in it can reach another session's state: a token only ever seeds the session
// that sent it.
#pragma once

#include <cstdint>
#include <string>

#include "common/matching/sequence_filter.h"
#include "common/util/status.h"

namespace sceneloc {

// Who a token belongs to: the session (client key name and session name) and the map.
struct TokenOwner {
  std::string client;
  std::string session;
  uint32_t map_key = 0;  // Map::PlacesKey
  int num_locations = 0;
  int num_speeds = 0;  // SequenceFilter::num_speeds() of the map's filter
};

std::string SerializeSessionToken(const SequenceState& state, const TokenOwner& owner);

enum class TokenFit {
  kFits,      // state filled: continue from it
  kOtherMap,  // a token of another map (or a version of it with other places): start again
};

// InvalidArgument naming the problem for a token that is corrupt (size, checksum, values,
// tracked locations out of order or past the map) or belongs to another session. A well-formed
// token of another map, or of a version with other places, is not an error: kOtherMap, and the
// session starts again.
StatusOr<TokenFit> ParseSessionToken(const std::string& bytes, const TokenOwner& owner,
                                     SequenceState* state);

}  // namespace sceneloc
