#include "server/session_token.h"

#include <cmath>
#include <cstring>
#include <string>

#include "common/map/crc32.h"

namespace sceneloc {
namespace {

constexpr char kMagic[4] = {'S', 'L', 'S', '6'};
// "SLS5": the same without the track's support; continues with a fresh support.
constexpr char kMagicNoSupport[4] = {'S', 'L', 'S', '5'};
// The earlier formats ("SLS1": N + 1 values; "SLS2": the direction of travel, 2N + 1;
// "SLS3": every location's speeds, S N + 1; "SLS4": no camera scale): well-formed ones
// start the session again, as a token of another map does.
constexpr char kOldMagics[4][4] = {
    {'S', 'L', 'S', '1'}, {'S', 'L', 'S', '2'}, {'S', 'L', 'S', '3'}, {'S', 'L', 'S', '4'}};
constexpr size_t kHeaderBytes = 4 + 4 + 4 + 4 + 4 + 4 + 4 + 8 + 4;

bool IsOldFormat(const std::string& bytes) {
  if (bytes.size() < 4) return false;
  for (const auto& magic : kOldMagics) {
    if (std::memcmp(bytes.data(), magic, 4) == 0) return true;
  }
  return false;
}

uint64_t SessionHash(const TokenOwner& owner) {
  uint64_t h = 14695981039346656037ull;  // FNV-1a, 64 bits
  const auto mix = [&h](const std::string& s) {
    for (const char c : s) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ull;
    h = (h ^ 0xff) * 1099511628211ull;  // separator: ("ab", "c") != ("a", "bc")
  };
  mix(owner.client);
  mix(owner.session);
  return h;
}

template <typename T>
void Put(std::string* out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // the machines we build for are little-endian
  out->append(bytes, sizeof(T));
}

template <typename T>
T Get(const std::string& in, size_t* at) {
  T value;
  std::memcpy(&value, in.data() + *at, sizeof(T));
  *at += sizeof(T);
  return value;
}

}  // namespace

std::string SerializeSessionToken(const SequenceState& state, const TokenOwner& owner) {
  std::string out;
  out.reserve(kHeaderBytes +
              4 * (state.location.size() + state.tracked.size() + state.speeds.size()) +
              2 * state.camera_counts.size() + 4);
  out.append(kMagic, sizeof(kMagic));
  Put<uint32_t>(&out, owner.map_key);
  Put<uint32_t>(&out, static_cast<uint32_t>(owner.num_locations));
  Put<uint32_t>(&out, static_cast<uint32_t>(owner.num_speeds));
  Put<uint32_t>(&out, static_cast<uint32_t>(state.tracked.size()));
  Put<uint32_t>(&out, state.frames);
  Put<uint32_t>(&out, static_cast<uint32_t>(state.camera_counts.size()));
  Put<uint64_t>(&out, SessionHash(owner));
  Put<float>(&out, state.support);
  for (const float p : state.location) Put<float>(&out, p);
  for (const uint32_t l : state.tracked) Put<uint32_t>(&out, l);
  for (const float p : state.speeds) Put<float>(&out, p);
  for (const uint16_t c : state.camera_counts) Put<uint16_t>(&out, c);
  Put<uint32_t>(&out, Crc32(out.data(), out.size()));
  return out;
}

StatusOr<TokenFit> ParseSessionToken(const std::string& bytes, const TokenOwner& owner,
                                     SequenceState* state) {
  const auto corrupt = [](const std::string& why) {
    return InvalidArgument("session_state is not a state this server made (" + why +
                           "): send the `state` of the session's last reply, or none");
  };
  const bool old_format = IsOldFormat(bytes);
  const bool no_support = bytes.size() >= 4 && std::memcmp(bytes.data(), kMagicNoSupport, 4) == 0;
  const size_t header = no_support ? kHeaderBytes - 4 : kHeaderBytes;
  if (bytes.size() < header + 4 ||
      (std::memcmp(bytes.data(), kMagic, 4) != 0 && !old_format && !no_support)) {
    return corrupt("no session state header");
  }
  const size_t body = bytes.size() - 4;
  size_t at = body;
  if (Get<uint32_t>(bytes, &at) != Crc32(bytes.data(), body)) return corrupt("checksum mismatch");
  if (old_format) return TokenFit::kOtherMap;
  at = sizeof(kMagic);
  const uint32_t checksum = Get<uint32_t>(bytes, &at);
  const uint32_t locations = Get<uint32_t>(bytes, &at);
  const uint32_t speeds = Get<uint32_t>(bytes, &at);
  const uint32_t tracked = Get<uint32_t>(bytes, &at);
  const uint32_t frames = Get<uint32_t>(bytes, &at);
  const uint32_t camera_bins = Get<uint32_t>(bytes, &at);
  const uint64_t session = Get<uint64_t>(bytes, &at);
  const float support = no_support ? SequenceState::kFreshSupport : Get<float>(bytes, &at);
  if (camera_bins != 0 && camera_bins != SequenceOptions::kCameraBins) {
    return corrupt("its camera scale has " + std::to_string(camera_bins) + " bins, not " +
                   std::to_string(SequenceOptions::kCameraBins));
  }
  // Every count is bounded by the token's own size (under 2^32 values) before they are
  // multiplied, in 64 bits.
  const size_t camera_bytes = 2 * size_t{camera_bins};
  const size_t state_bytes = body - header;
  const size_t values = state_bytes >= camera_bytes ? (state_bytes - camera_bytes) / 4 : 0;
  if (state_bytes < camera_bytes || (state_bytes - camera_bytes) % 4 != 0 || locations == 0 ||
      speeds == 0 || locations > values || speeds > values || tracked > locations ||
      SequenceFilter::StateValues(locations, speeds, tracked) != values) {
    return corrupt("size does not match its location, speed, tracked and camera counts");
  }
  if (session != SessionHash(owner)) {
    return InvalidArgument("session_state belongs to another session (another name or key)");
  }
  // Another map, a version of it with other places, or other filter settings (speeds): start
  // again.
  if (checksum != owner.map_key || static_cast<int>(locations) != owner.num_locations ||
      static_cast<int>(speeds) != owner.num_speeds) {
    return TokenFit::kOtherMap;
  }
  if (!(support >= 0 && support <= 1)) return corrupt("its track's support is not in [0, 1]");
  SequenceState parsed;
  parsed.frames = frames;
  parsed.support = support;
  // Non-negative finite values with a positive sum, scaled to sum to 1.
  const auto read_distribution = [&](float* out, size_t count) -> Status {
    double total = 0;
    for (size_t i = 0; i < count; ++i) {
      out[i] = Get<float>(bytes, &at);
      if (!std::isfinite(out[i]) || out[i] < 0) {
        return corrupt("a belief value is negative or not finite");
      }
      total += out[i];
    }
    if (!(total > 0)) return corrupt("a distribution in it sums to zero");
    for (size_t i = 0; i < count; ++i) out[i] = static_cast<float>(out[i] / total);
    return Status::Ok();
  };
  parsed.location.resize(locations + size_t{1});
  SCENELOC_RETURN_IF_ERROR(read_distribution(parsed.location.data(), parsed.location.size()));
  parsed.tracked.resize(tracked);
  for (size_t i = 0; i < tracked; ++i) {
    parsed.tracked[i] = Get<uint32_t>(bytes, &at);
    if (parsed.tracked[i] >= locations || (i > 0 && parsed.tracked[i] <= parsed.tracked[i - 1])) {
      return corrupt("its tracked locations are not ascending locations of the map");
    }
  }
  parsed.speeds.resize((tracked + size_t{1}) * speeds);
  for (size_t row = 0; row <= tracked; ++row) {
    SCENELOC_RETURN_IF_ERROR(read_distribution(parsed.speeds.data() + row * speeds, speeds));
  }
  // Any counts are a camera scale measured somewhere in [-kCameraRange, kCameraRange]: the
  // worst a forged one does is read that session's own frames at another scale.
  parsed.camera_counts.resize(camera_bins);
  for (uint16_t& c : parsed.camera_counts) c = Get<uint16_t>(bytes, &at);
  *state = std::move(parsed);
  return TokenFit::kFits;
}

}  // namespace sceneloc
