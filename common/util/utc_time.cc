#include "common/util/utc_time.h"

#include <ctime>

namespace sceneloc {

std::string UtcText(std::chrono::system_clock::time_point t, const char* format) {
  const std::time_t seconds = std::chrono::system_clock::to_time_t(t);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[64];
  const size_t n = std::strftime(text, sizeof(text), format, &tm);
  return std::string(text, n);
}

}  // namespace sceneloc
