#include "server/session_token.h"

#include <gtest/gtest.h>

#include <cmath>

namespace sceneloc {
namespace {

TokenOwner Owner(const std::string& session = "robot-1", uint32_t checksum = 0xabcdef01u) {
  return {"robot-key", session, checksum, 4};
}

SequenceState State() {
  SequenceState s;
  s.belief = {0.1f, 0.6f, 0.2f, 0.05f, 0.05f};  // 4 locations and off-map
  s.frames = 17;
  return s;
}

// A state survives the round trip exactly; its size is 28 + 4 (N + 1) bytes.
TEST(SessionTokenTest, RoundTrip) {
  const std::string bytes = SerializeSessionToken(State(), Owner());
  EXPECT_EQ(bytes.size(), 28u + 4 * 5);
  SequenceState parsed;
  auto fit = ParseSessionToken(bytes, Owner(), &parsed);
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  EXPECT_EQ(*fit, TokenFit::kFits);
  EXPECT_EQ(parsed.frames, 17u);
  ASSERT_EQ(parsed.belief.size(), 5u);
  for (size_t i = 0; i < 5; ++i) EXPECT_NEAR(parsed.belief[i], State().belief[i], 1e-6);
}

// Any flipped byte, a truncation or no header at all: INVALID_ARGUMENT, state untouched.
TEST(SessionTokenTest, CorruptTokensAreRefused) {
  const std::string good = SerializeSessionToken(State(), Owner());
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
  SequenceState s = State();
  SequenceState parsed;
  s.belief[2] = std::nanf("");
  EXPECT_NE(ParseSessionToken(SerializeSessionToken(s, Owner()), Owner(), &parsed)
                .status()
                .message()
                .find("not finite"),
            std::string::npos);
  s = State();
  s.belief[1] = -0.5f;
  EXPECT_FALSE(ParseSessionToken(SerializeSessionToken(s, Owner()), Owner(), &parsed).ok());
  s.belief.assign(5, 0.0f);
  EXPECT_NE(ParseSessionToken(SerializeSessionToken(s, Owner()), Owner(), &parsed)
                .status()
                .message()
                .find("sums to zero"),
            std::string::npos);
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
}

}  // namespace
}  // namespace sceneloc
