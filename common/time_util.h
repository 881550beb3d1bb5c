#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace semmap {

inline int64_t UnixNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// Milliseconds elapsed on the steady clock since `start` (stage timings).
inline double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// Seconds with microsecond digits, as TUM files write stamps ("1341841873.273798").
std::string FormatStampSeconds(int64_t stamp_ns);
// Parses "1341841873.273798" exactly (no double rounding); false on malformed text.
bool ParseStampSeconds(const std::string& text, int64_t* stamp_ns);

}  // namespace semmap
