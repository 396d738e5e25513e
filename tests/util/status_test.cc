// Status and StatusOr (common/util/status.h): names, text, and the early-return macros.
#include "common/util/status.h"

#include <gtest/gtest.h>

#include <memory>
#include <set>
#include <string>

namespace sceneloc {
namespace {

// Every code has its own upper-case name; OK is "OK".
TEST(StatusTest, EveryCodeHasItsOwnName) {
  std::set<std::string> names;
  for (int c = 0; c <= static_cast<int>(StatusCode::kPermissionDenied); ++c) {
    names.insert(StatusCodeName(static_cast<StatusCode>(c)));
  }
  EXPECT_EQ(names.size(), static_cast<size_t>(StatusCode::kPermissionDenied) + 1);
  EXPECT_STREQ(StatusCodeName(StatusCode::kOk), "OK");
  EXPECT_STREQ(StatusCodeName(StatusCode::kDataLoss), "DATA_LOSS");
}

// ToString is "CODE: message", or just "OK"; the helpers set the code they are named for.
TEST(StatusTest, ToStringAndHelpers) {
  EXPECT_EQ(Status::Ok().ToString(), "OK");
  EXPECT_EQ(NotFound("no map 'lab'").ToString(), "NOT_FOUND: no map 'lab'");
  EXPECT_EQ(IoError("x").code(), StatusCode::kIoError);
  EXPECT_EQ(DeadlineExceeded("x").code(), StatusCode::kDeadlineExceeded);
  EXPECT_EQ(PermissionDenied("x").code(), StatusCode::kPermissionDenied);
  EXPECT_FALSE(Internal("x").ok());
}

// A StatusOr holds a value (movable, even move-only) or a failed status, never both.
TEST(StatusTest, StatusOrHoldsAValueOrAStatus) {
  StatusOr<std::unique_ptr<int>> value(std::make_unique<int>(7));
  ASSERT_TRUE(value.ok());
  EXPECT_EQ(**value, 7);
  const std::unique_ptr<int> taken = std::move(value).value();
  EXPECT_EQ(*taken, 7);
  const StatusOr<int> failed(InvalidArgument("bad"));
  EXPECT_FALSE(failed.ok());
  EXPECT_EQ(failed.status().message(), "bad");
}

Status FailsWhen(bool fail) { return fail ? DataLoss("broken") : Status::Ok(); }

StatusOr<int> Half(int x) {
  if (x % 2 != 0) return InvalidArgument(std::to_string(x) + " is odd");
  return x / 2;
}

// Quarter(x) with both macros: the first failure returns at once with its status.
StatusOr<int> Quarter(int x, bool fail_first, int* steps) {
  SCENELOC_RETURN_IF_ERROR(FailsWhen(fail_first));
  ++*steps;
  SCENELOC_ASSIGN_OR_RETURN(const int half, Half(x));
  ++*steps;
  SCENELOC_ASSIGN_OR_RETURN(const int quarter, Half(half));
  return quarter;
}

// The macros pass a failure up unchanged and stop there; on success they carry on.
TEST(StatusTest, MacrosReturnEarlyWithTheFailure) {
  int steps = 0;
  const StatusOr<int> ok = Quarter(12, false, &steps);
  ASSERT_TRUE(ok.ok());
  EXPECT_EQ(*ok, 3);
  EXPECT_EQ(steps, 2);
  steps = 0;
  EXPECT_EQ(Quarter(12, true, &steps).status().code(), StatusCode::kDataLoss);
  EXPECT_EQ(steps, 0);
  const StatusOr<int> odd = Quarter(6, false, &steps);
  EXPECT_EQ(odd.status().message(), "3 is odd");
  EXPECT_EQ(steps, 2);
}

}  // namespace
}  // namespace sceneloc
