#include "common/time_util.h"

#include <cctype>
#include <cinttypes>
#include <cmath>
#include <cstdio>

namespace semmap {

std::string FormatStampSeconds(int64_t stamp_ns) {
  const bool negative = stamp_ns < 0;
  const uint64_t abs_ns = negative ? static_cast<uint64_t>(-stamp_ns) : stamp_ns;
  // Round to microseconds.
  const uint64_t us = (abs_ns + 500) / 1000;
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%s%" PRIu64 ".%06" PRIu64, negative ? "-" : "", us / 1000000,
                us % 1000000);
  return buf;
}

bool ParseStampSeconds(const std::string& text, int64_t* stamp_ns) {
  size_t i = 0;
  bool negative = false;
  if (i < text.size() && (text[i] == '-' || text[i] == '+')) negative = text[i++] == '-';
  int64_t whole = 0;
  size_t digits = 0;
  while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
    whole = whole * 10 + (text[i++] - '0');
    if (whole > 9'000'000'000LL) return false;  // beyond int64 nanoseconds (year 2255)
    ++digits;
  }
  int64_t frac_ns = 0;
  if (i < text.size() && text[i] == '.') {
    ++i;
    int64_t scale = 100'000'000;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
      frac_ns += (text[i++] - '0') * scale;
      scale /= 10;
      ++digits;
    }
  }
  if (digits == 0) return false;
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    // Scientific notation (KITTI times.txt): fall back to double.
    double v = 0;
    if (std::sscanf(text.c_str(), "%lf", &v) != 1 || !(std::abs(v) <= 9e9)) return false;
    *stamp_ns = static_cast<int64_t>(v * 1e9 + (v >= 0 ? 0.5 : -0.5));
    return true;
  }
  if (i != text.size()) return false;
  const int64_t ns = whole * 1'000'000'000LL + frac_ns;
  *stamp_ns = negative ? -ns : ns;
  return true;
}

}  // namespace semmap
