// Size arithmetic on numbers that come from outside (wire messages, files, stored bytes).
// Every product or sum that sizes a buffer, an allocation or a read goes through these, so a
// wrap-around becomes an error instead of a small number that passes the next check.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <limits>
#include <optional>
#include <type_traits>

namespace semmap {

// a * b, or nullopt when the product does not fit in 64 bits.
constexpr std::optional<uint64_t> CheckedMul(uint64_t a, uint64_t b) {
  uint64_t out = 0;
  if (__builtin_mul_overflow(a, b, &out)) return std::nullopt;
  return out;
}

// a + b, or nullopt when the sum does not fit in 64 bits.
constexpr std::optional<uint64_t> CheckedAdd(uint64_t a, uint64_t b) {
  uint64_t out = 0;
  if (__builtin_add_overflow(a, b, &out)) return std::nullopt;
  return out;
}

// The product of all factors (1 for none), or nullopt on overflow.
constexpr std::optional<uint64_t> CheckedProduct(std::initializer_list<uint64_t> factors) {
  uint64_t out = 1;
  for (const uint64_t f : factors) {
    const std::optional<uint64_t> next = CheckedMul(out, f);
    if (!next) return std::nullopt;
    out = *next;
  }
  return out;
}

// `value` as an integer type `To` (int for OpenCV sizes, size_t, int64_t for SQLite), or nullopt
// when it does not fit.
template <typename To>
constexpr std::optional<To> CheckedNarrow(uint64_t value) {
  static_assert(std::is_integral_v<To>);
  if (value > static_cast<uint64_t>(std::numeric_limits<To>::max())) return std::nullopt;
  return static_cast<To>(value);
}

}  // namespace semmap
