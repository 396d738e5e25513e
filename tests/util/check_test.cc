// SCENELOC_CHECK (common/util/check.h): a true condition passes without formatting its
// message; a false one writes where, what and why, and aborts, in Release too. StatusOr
// checks it holds a value before it gives one.
#include "common/util/check.h"

#include <gtest/gtest.h>

#include "common/util/status.h"

namespace sceneloc {
namespace {

int Formatted(int* count) {
  ++*count;
  return 0;
}

TEST(CheckTest, ATrueConditionPassesWithoutItsMessage) {
  int formatted = 0;
  SCENELOC_CHECK(1 + 1 == 2) << Formatted(&formatted);
  EXPECT_EQ(formatted, 0);
  if (formatted == 0)
    SCENELOC_CHECK(true) << "no dangling else";
  else
    ADD_FAILURE() << "the else bound to the check";
}

TEST(CheckDeathTest, AFalseConditionSaysWhereWhatAndWhyThenAborts) {
  const int held = 0;
  EXPECT_DEATH(SCENELOC_CHECK(held > 0) << "held " << held,
               "check_test.cc:[0-9]+: check failed: held > 0: held 0");
  EXPECT_DEATH(SCENELOC_CHECK(held == 1), "check failed: held == 1\n");
}

TEST(CheckDeathTest, StatusOrChecksItHoldsAValue) {
  StatusOr<int> error = NotFound("no such map");
  EXPECT_DEATH((void)error.value(), "the value of an error: NOT_FOUND: no such map");
  EXPECT_DEATH((void)*error, "the value of an error");
  EXPECT_DEATH((void)StatusOr<int>(Status::Ok()), "made from an OK status");
  StatusOr<int> fine = 3;
  EXPECT_EQ(fine.value(), 3);
}

}  // namespace
}  // namespace sceneloc
