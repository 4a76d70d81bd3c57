#pragma once
// Wall-clock time as ISO-8601 UTC text for logs and session state.
#include <chrono>
#include <ctime>
#include <string>

namespace mrsns::workflow {

inline std::string isoTimeNow() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

}  // namespace mrsns::workflow
