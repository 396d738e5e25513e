// Status and StatusOr<T>: how every stage reports a failure a user can cause (a bad
// file, a bad request, a bad setting). Broken invariants are checks, not statuses.
//
// Thread-safe: values are immutable once built and safe to copy between threads.
#pragma once

#include <optional>
#include <string>
#include <utility>

#include "common/util/check.h"

namespace sceneloc {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,     // a setting, a request field or an input value is wrong
  kNotFound,            // a file, a map or a tour image does not exist
  kDataLoss,            // a file is truncated, corrupt or fails its checksum
  kFailedPrecondition,  // the input is well-formed but cannot be used (e.g. too few images)
  kUnimplemented,       // e.g. a map file of a newer format version
  kResourceExhausted,   // a size cap was exceeded
  kInternal,            // a library threw something we did not expect
  kIoError,             // the operating system refused a read or a write
  kDeadlineExceeded,    // the work did not finish within its time budget
  kPermissionDenied,    // the caller is known but may not do this (e.g. reload without admin)
};

const char* StatusCodeName(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status Ok() { return Status(); }
  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  // "NOT_FOUND: tour folder 'x' does not exist"
  std::string ToString() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status InvalidArgument(std::string m) {
  return {StatusCode::kInvalidArgument, std::move(m)};
}
inline Status NotFound(std::string m) { return {StatusCode::kNotFound, std::move(m)}; }
inline Status DataLoss(std::string m) { return {StatusCode::kDataLoss, std::move(m)}; }
inline Status FailedPrecondition(std::string m) {
  return {StatusCode::kFailedPrecondition, std::move(m)};
}
inline Status Unimplemented(std::string m) { return {StatusCode::kUnimplemented, std::move(m)}; }
inline Status ResourceExhausted(std::string m) {
  return {StatusCode::kResourceExhausted, std::move(m)};
}
inline Status Internal(std::string m) { return {StatusCode::kInternal, std::move(m)}; }
inline Status IoError(std::string m) { return {StatusCode::kIoError, std::move(m)}; }
inline Status DeadlineExceeded(std::string m) {
  return {StatusCode::kDeadlineExceeded, std::move(m)};
}
inline Status PermissionDenied(std::string m) {
  return {StatusCode::kPermissionDenied, std::move(m)};
}

// Either a value or a non-OK status.
template <typename T>
class [[nodiscard]] StatusOr {
 public:
  // REQUIRES (checked): !status.ok().
  StatusOr(Status status) : status_(std::move(status)) {  // NOLINT
    SCENELOC_CHECK(!status_.ok()) << "a StatusOr made from an OK status holds no value";
  }
  StatusOr(T value) : value_(std::move(value)) {}  // NOLINT

  bool ok() const { return status_.ok(); }
  const Status& status() const { return status_; }
  // REQUIRES (checked, in Release too: reading an error as a value would go on with
  // garbage): ok().
  const T& value() const& { return *Checked(); }
  T& value() & { return *Checked(); }
  T&& value() && { return std::move(*Checked()); }
  const T& operator*() const& { return *Checked(); }
  T& operator*() & { return *Checked(); }
  const T* operator->() const { return &*Checked(); }
  T* operator->() { return &*Checked(); }

 private:
  const std::optional<T>& Checked() const {
    SCENELOC_CHECK(value_.has_value()) << "the value of an error: " << status_.ToString();
    return value_;
  }
  std::optional<T>& Checked() {
    SCENELOC_CHECK(value_.has_value()) << "the value of an error: " << status_.ToString();
    return value_;
  }

  Status status_;
  std::optional<T> value_;
};

}  // namespace sceneloc

// Returns early with the status of `expr` when it is not OK.
#define SCENELOC_RETURN_IF_ERROR(expr)   \
  do {                                   \
    ::sceneloc::Status _status = (expr); \
    if (!_status.ok()) return _status;   \
  } while (0)

#define SCENELOC_CONCAT_INNER(a, b) a##b
#define SCENELOC_CONCAT(a, b) SCENELOC_CONCAT_INNER(a, b)
// Declares `lhs` from a StatusOr expression, returning its status on failure.
#define SCENELOC_ASSIGN_OR_RETURN(lhs, expr) \
  SCENELOC_ASSIGN_OR_RETURN_IMPL(SCENELOC_CONCAT(_status_or_, __LINE__), lhs, expr)
#define SCENELOC_ASSIGN_OR_RETURN_IMPL(tmp, lhs, expr) \
  auto tmp = (expr);                                   \
  if (!tmp.ok()) return tmp.status();                  \
  lhs = std::move(tmp).value()
