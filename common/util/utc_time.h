// Wall-clock times as UTC text: map provenance, kept frames, the server's replies.
#pragma once

#include <chrono>
#include <string>

namespace sceneloc {

// ISO 8601 to the second: "2026-12-08T01:55:15Z".
inline constexpr char kIsoUtcFormat[] = "%Y-%m-%dT%H:%M:%SZ";

// `t` in UTC as strftime's `format` writes it (at most 63 characters).
std::string UtcText(std::chrono::system_clock::time_point t, const char* format = kIsoUtcFormat);

}  // namespace sceneloc
