#include "server/session_token.h"

#include <cmath>
#include <cstring>

#include "common/map/crc32.h"

namespace sceneloc {
namespace {

constexpr char kMagic[4] = {'S', 'L', 'S', '3'};
// The formats before the speed was state ("SLS1": N + 1 values; "SLS2": the direction of
// travel, 2N + 1): well-formed ones start the session again, as a token of another map does.
constexpr char kOldMagics[2][4] = {{'S', 'L', 'S', '1'}, {'S', 'L', 'S', '2'}};
constexpr size_t kHeaderBytes = 4 + 4 + 4 + 4 + 4 + 8;

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
  out.reserve(kHeaderBytes + 4 * state.belief.size() + 4);
  out.append(kMagic, sizeof(kMagic));
  Put<uint32_t>(&out, owner.map_checksum);
  Put<uint32_t>(&out, static_cast<uint32_t>(owner.num_locations));
  Put<uint32_t>(&out, static_cast<uint32_t>(owner.num_speeds));
  Put<uint32_t>(&out, state.frames);
  Put<uint64_t>(&out, SessionHash(owner));
  for (const float b : state.belief) Put<float>(&out, b);
  Put<uint32_t>(&out, Crc32(out.data(), out.size()));
  return out;
}

StatusOr<TokenFit> ParseSessionToken(const std::string& bytes, const TokenOwner& owner,
                                     SequenceState* state) {
  const auto corrupt = [](const std::string& why) {
    return InvalidArgument("session_state is not a state this server made (" + why +
                           "): send the `state` of the session's last reply, or none");
  };
  const bool old_format = bytes.size() >= 4 && (std::memcmp(bytes.data(), kOldMagics[0], 4) == 0 ||
                                                std::memcmp(bytes.data(), kOldMagics[1], 4) == 0);
  if (bytes.size() < kHeaderBytes + 4 ||
      (std::memcmp(bytes.data(), kMagic, 4) != 0 && !old_format)) {
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
  const uint32_t frames = Get<uint32_t>(bytes, &at);
  const uint64_t session = Get<uint64_t>(bytes, &at);
  // Both counts are bounded by the token's own size before they are multiplied.
  const size_t floats = (body - kHeaderBytes) / 4;
  if ((body - kHeaderBytes) % 4 != 0 || locations == 0 || speeds == 0 || locations > floats ||
      speeds > floats ||
      SequenceFilter::StateSize(static_cast<int>(locations), static_cast<int>(speeds)) != floats) {
    return corrupt("size does not match its location and speed counts");
  }
  if (session != SessionHash(owner)) {
    return InvalidArgument("session_state belongs to another session (another name or key)");
  }
  // Another map, map version, or filter settings (another number of speeds): start again.
  if (checksum != owner.map_checksum || static_cast<int>(locations) != owner.num_locations ||
      static_cast<int>(speeds) != owner.num_speeds) {
    return TokenFit::kOtherMap;
  }
  SequenceState parsed;
  parsed.frames = frames;
  parsed.belief.resize(floats);
  double total = 0;
  for (float& b : parsed.belief) {
    b = Get<float>(bytes, &at);
    if (!std::isfinite(b) || b < 0) return corrupt("a belief value is negative or not finite");
    total += b;
  }
  if (!(total > 0)) return corrupt("the belief sums to zero");
  for (float& b : parsed.belief) b = static_cast<float>(b / total);
  *state = std::move(parsed);
  return TokenFit::kFits;
}

}  // namespace sceneloc
