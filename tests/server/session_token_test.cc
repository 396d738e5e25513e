#include "server/session_token.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "common/map/crc32.h"

namespace sceneloc {
namespace {

TokenOwner Owner(const std::string& session = "robot-1", uint32_t checksum = 0xabcdef01u) {
  return {"robot-key", session, checksum, 4, 2};
}

SequenceState State() {
  SequenceState s;
  // 4 locations and off-map; locations 1 and 2 keep their two speeds, 0 and 3 share one.
  s.location = {0.1f, 0.6f, 0.2f, 0.05f, 0.05f};
  s.tracked = {1, 2};
  s.speeds = {0.5f, 0.5f, 0.25f, 0.75f, 1.0f, 0.0f};
  s.frames = 17;
  s.support = 0.3f;
  return s;
}

// The state of a session that has measured its camera's scale.
SequenceState StateWithCamera() {
  SequenceState s = State();
  s.camera_counts.assign(SequenceOptions::kCameraBins, 0);
  s.camera_counts[20] = 3;
  s.camera_counts[41] = 65535;
  return s;
}

// A state survives the round trip exactly; its size is 44 + 4 (N + 1 + K + (K + 1) S) + 2 B
// bytes, B the camera's bins (0 until the session measures its camera).
TEST(SessionTokenTest, RoundTrip) {
  for (const SequenceState& state : {State(), StateWithCamera()}) {
    const std::string bytes = SerializeSessionToken(state, Owner());
    EXPECT_EQ(bytes.size(), 44u + 4 * (5 + 2 + 6) + 2 * state.camera_counts.size());
    SequenceState parsed;
    auto fit = ParseSessionToken(bytes, Owner(), &parsed);
    ASSERT_TRUE(fit.ok()) << fit.status().ToString();
    EXPECT_EQ(*fit, TokenFit::kFits);
    EXPECT_EQ(parsed.frames, 17u);
    EXPECT_EQ(parsed.location, state.location);
    EXPECT_EQ(parsed.tracked, state.tracked);
    EXPECT_EQ(parsed.speeds, state.speeds);
    EXPECT_EQ(parsed.camera_counts, state.camera_counts);
    EXPECT_EQ(parsed.support, 0.3f);
  }
}

// A "SLS5" token (the format before the track's support: the same bytes without it) that a
// client kept across the server's upgrade continues, with a fresh support; damaged, it is
// refused.
TEST(SessionTokenTest, TokensWithoutSupportContinue) {
  std::string bytes = SerializeSessionToken(StateWithCamera(), Owner());
  bytes[3] = '5';
  bytes.erase(36, sizeof(float));  // the support, after the session hash
  bytes.resize(bytes.size() - sizeof(uint32_t));
  const uint32_t crc = Crc32(bytes.data(), bytes.size());
  bytes.append(reinterpret_cast<const char*>(&crc), sizeof(crc));
  SequenceState parsed;
  const auto fit = ParseSessionToken(bytes, Owner(), &parsed);
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  EXPECT_EQ(*fit, TokenFit::kFits);
  EXPECT_EQ(parsed.support, SequenceState::kFreshSupport);
  EXPECT_EQ(parsed.location, StateWithCamera().location);
  EXPECT_EQ(parsed.camera_counts, StateWithCamera().camera_counts);
  bytes[50] = static_cast<char>(bytes[50] ^ 0x20);
  EXPECT_EQ(ParseSessionToken(bytes, Owner(), &parsed).status().code(),
            StatusCode::kInvalidArgument);
}

// Tokens of the earlier formats ("SLS1": N + 1 values; "SLS2": the direction of travel,
// 2N + 1; "SLS3": every location's speeds, S N + 1; "SLS4": the tracked locations' speeds,
// no camera) that a client kept across the server's upgrade start their session again: not
// an error. The same bytes damaged are still
// refused.
TEST(SessionTokenTest, EarlierFormatsStartAgain) {
  struct Old {
    const char* magic;
    std::vector<uint32_t> header;  // after the magic: map checksum, counts, frames
    int values;
  };
  const Old olds[] = {{"SLS1", {0xabcdef01u, 4, 17}, 5},
                      {"SLS2", {0xabcdef01u, 4, 17}, 9},
                      {"SLS3", {0xabcdef01u, 4, 2, 17}, 9},
                      {"SLS4", {0xabcdef01u, 4, 2, 2, 17}, 13}};
  for (const Old& o : olds) {
    SCOPED_TRACE(o.magic);
    std::string old(o.magic);
    const auto put = [&old](const void* p, size_t n) {
      old.append(static_cast<const char*>(p), n);
    };
    const uint64_t session_hash = 0;
    const std::vector<float> belief(static_cast<size_t>(o.values), 1.0f / o.values);
    put(o.header.data(), o.header.size() * sizeof(uint32_t));
    put(&session_hash, sizeof(session_hash));
    put(belief.data(), belief.size() * sizeof(float));
    const uint32_t crc = Crc32(old.data(), old.size());
    put(&crc, sizeof(crc));
    SequenceState parsed;
    parsed.frames = 99;
    const auto fit = ParseSessionToken(old, Owner(), &parsed);
    ASSERT_TRUE(fit.ok()) << fit.status().ToString();
    EXPECT_EQ(*fit, TokenFit::kOtherMap);
    EXPECT_EQ(parsed.frames, 99u);
    old[10] = static_cast<char>(old[10] ^ 0x20);
    EXPECT_EQ(ParseSessionToken(old, Owner(), &parsed).status().code(),
              StatusCode::kInvalidArgument);
  }
}

// Any flipped byte, a truncation or no header at all: INVALID_ARGUMENT, state untouched.
TEST(SessionTokenTest, CorruptTokensAreRefused) {
  const std::string good = SerializeSessionToken(StateWithCamera(), Owner());
  SequenceState parsed;
  parsed.frames = 99;
  for (size_t i = 0; i < good.size(); ++i) {
    std::string bad = good;
    bad[i] = static_cast<char>(bad[i] ^ 0x20);
    const auto fit = ParseSessionToken(bad, Owner(), &parsed);
    EXPECT_EQ(fit.status().code(), StatusCode::kInvalidArgument) << "byte " << i;
  }
  for (const std::string& bad : {good.substr(0, good.size() - 1), good.substr(0, 10), std::string(),
                                 std::string("SLS1"), good + "x"}) {
    EXPECT_EQ(ParseSessionToken(bad, Owner(), &parsed).status().code(),
              StatusCode::kInvalidArgument);
  }
  EXPECT_EQ(parsed.frames, 99u);
}

// A token made with a valid checksum but impossible values (forged) is refused too.
TEST(SessionTokenTest, ForgedValuesAreRefused) {
  const auto refusal = [](const SequenceState& s) {
    SequenceState parsed;
    const auto fit = ParseSessionToken(SerializeSessionToken(s, Owner()), Owner(), &parsed);
    EXPECT_FALSE(fit.ok());
    return std::string(fit.status().message());
  };
  SequenceState s = State();
  s.support = 1.5f;
  EXPECT_NE(refusal(s).find("support"), std::string::npos);
  s.support = std::nanf("");
  EXPECT_NE(refusal(s).find("support"), std::string::npos);
  s = State();
  s.location[2] = std::nanf("");
  EXPECT_NE(refusal(s).find("not finite"), std::string::npos);
  s = State();
  s.location[1] = -0.5f;
  EXPECT_NE(refusal(s).find("negative"), std::string::npos);
  s = State();
  s.speeds[3] = std::numeric_limits<float>::infinity();
  EXPECT_NE(refusal(s).find("not finite"), std::string::npos);
  s = State();
  s.location.assign(5, 0.0f);
  EXPECT_NE(refusal(s).find("sums to zero"), std::string::npos);
  s = State();
  s.speeds[4] = 0;  // the shared row
  s.speeds[5] = 0;
  EXPECT_NE(refusal(s).find("sums to zero"), std::string::npos);
  s = State();
  s.tracked = {2, 1};
  EXPECT_NE(refusal(s).find("tracked locations"), std::string::npos);
  s.tracked = {1, 1};
  EXPECT_NE(refusal(s).find("tracked locations"), std::string::npos);
  s.tracked = {1, 4};  // past the map's 4 locations
  EXPECT_NE(refusal(s).find("tracked locations"), std::string::npos);
  s = State();
  s.camera_counts.assign(SequenceOptions::kCameraBins - 1, 1);
  EXPECT_NE(refusal(s).find("camera scale has 63 bins"), std::string::npos);
  s.camera_counts.assign(SequenceOptions::kCameraBins + 1, 1);
  EXPECT_NE(refusal(s).find("camera scale has 65 bins"), std::string::npos);
}

// Another session's token (name or key) is refused; another map's starts the session again.
TEST(SessionTokenTest, OwnerChecked) {
  const std::string bytes = SerializeSessionToken(State(), Owner());
  SequenceState parsed;
  const auto other_session = ParseSessionToken(bytes, Owner("robot-2"), &parsed);
  EXPECT_NE(other_session.status().message().find("another session"), std::string::npos);
  TokenOwner other_key = Owner();
  other_key.client = "other-key";
  EXPECT_FALSE(ParseSessionToken(bytes, other_key, &parsed).ok());
  auto other_map = ParseSessionToken(bytes, Owner("robot-1", 0x12345678u), &parsed);
  ASSERT_TRUE(other_map.ok());
  EXPECT_EQ(*other_map, TokenFit::kOtherMap);
  TokenOwner bigger = Owner();
  bigger.num_locations = 5;
  auto resized = ParseSessionToken(bytes, bigger, &parsed);
  ASSERT_TRUE(resized.ok());
  EXPECT_EQ(*resized, TokenFit::kOtherMap);
  // A server whose filter has other speeds (other settings) starts the session again.
  TokenOwner faster = Owner();
  faster.num_speeds = 3;
  auto other_speeds = ParseSessionToken(bytes, faster, &parsed);
  ASSERT_TRUE(other_speeds.ok());
  EXPECT_EQ(*other_speeds, TokenFit::kOtherMap);
}

// Counts that do not add up to the token's size (forged, with a valid checksum) are
// refused before anything is allocated: each past the token's values, more tracked
// locations than locations, and counts each in range whose total is not the size.
TEST(SessionTokenTest, CountsThatDoNotFitTheTokenAreRefused) {
  const auto parse = [](uint32_t locations, uint32_t speeds, uint32_t tracked) {
    std::string bytes = SerializeSessionToken(State(), Owner());
    std::memcpy(&bytes[8], &locations, 4);
    std::memcpy(&bytes[12], &speeds, 4);
    std::memcpy(&bytes[16], &tracked, 4);
    const uint32_t crc = Crc32(bytes.data(), bytes.size() - 4);
    std::memcpy(&bytes[bytes.size() - 4], &crc, 4);
    SequenceState parsed;
    return ParseSessionToken(bytes, Owner(), &parsed).status();
  };
  const auto refused = [](const Status& s) {
    return s.code() == StatusCode::kInvalidArgument &&
           s.message().find("size does not match") != std::string::npos;
  };
  const uint32_t huge = 0x40000001u;
  EXPECT_TRUE(refused(parse(huge, huge, huge)));
  EXPECT_TRUE(refused(parse(4, 2, 5)));  // more tracked locations than locations
  // Each in range, totals not the token's 13 values (N + 1 + K + (K + 1) S = 5 + 2 + 6).
  EXPECT_TRUE(refused(parse(2, 3, 1)));  // 3 + 1 + 6
  EXPECT_TRUE(refused(parse(4, 1, 3)));  // 5 + 3 + 4
  EXPECT_TRUE(parse(4, 2, 2).ok());      // the true counts: the refusals are the size's
}

// A token that tracks another number of locations than this server's filter keeps (a
// fleet whose tracked_locations is being changed) continues: the next frame compacts it.
TEST(SessionTokenTest, AnyNumberOfTrackedLocationsFits) {
  SequenceState none = State();
  none.tracked.clear();
  none.speeds = {0.5f, 0.5f};
  SequenceState all = State();
  all.tracked = {0, 1, 2, 3};
  all.speeds = {0.5f, 0.5f, 0.5f, 0.5f, 0.25f, 0.75f, 1.0f, 0.0f, 0.5f, 0.5f};
  for (const SequenceState& state : {none, all}) {
    SequenceState parsed;
    const auto fit = ParseSessionToken(SerializeSessionToken(state, Owner()), Owner(), &parsed);
    ASSERT_TRUE(fit.ok()) << fit.status().ToString();
    EXPECT_EQ(*fit, TokenFit::kFits);
    EXPECT_EQ(parsed.tracked, state.tracked);
  }
}

}  // namespace
}  // namespace sceneloc
