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

// |a - b| in nanoseconds, exact for any two stamps (their signed difference could overflow:
// stamps may be anywhere in the int64 range).
constexpr uint64_t StampDistanceNs(int64_t a, int64_t b) {
  return a > b ? static_cast<uint64_t>(a) - static_cast<uint64_t>(b)
               : static_cast<uint64_t>(b) - static_cast<uint64_t>(a);
}

// Seconds with microsecond digits, as TUM files write stamps ("1341841873.273798").
std::string FormatStampSeconds(int64_t stamp_ns);
// Parses "1341841873.273798" exactly (no double rounding); false on malformed text.
bool ParseStampSeconds(const std::string& text, int64_t* stamp_ns);

}  // namespace semmap
