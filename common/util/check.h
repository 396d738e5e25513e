// Invariants that stay checked in the Release build the server runs:
//
//   SCENELOC_CHECK(held > 0) << "Done(true) without a large item popped";
//
// When the condition is false, writes "file:line: check failed: <condition>: <message>" to
// stderr (where the server's log goes) and aborts: a broken invariant is a bug, and going on
// would corrupt state silently (an empty StatusOr read as a value, a counter below zero).
// The message is only formatted when the check fails. `assert` stays only where a check is
// too costly for Release.
//
// Thread-safe: a failing check writes one line and ends the process.
#pragma once

#include <sstream>

namespace sceneloc::internal {

// Collects a failed check's message; its destructor reports it and aborts.
class CheckFailure {
 public:
  CheckFailure(const char* file, int line, const char* condition);
  [[noreturn]] ~CheckFailure();
  CheckFailure(const CheckFailure&) = delete;
  CheckFailure& operator=(const CheckFailure&) = delete;
  std::ostream& stream() { return message_; }

 private:
  const char* const file_;
  const int line_;
  const char* const condition_;
  std::ostringstream message_;
};

}  // namespace sceneloc::internal

// A `while` rather than an `if`: no dangling else, and the body never repeats (it aborts).
#define SCENELOC_CHECK(condition) \
  while (!(condition)) ::sceneloc::internal::CheckFailure(__FILE__, __LINE__, #condition).stream()
