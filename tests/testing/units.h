// Unit constants the tests share. One definition each: a target's test files are compiled
// together in unity batches, where per-file copies would collide.
#pragma once

#include <cstdint>
#include <numbers>

namespace semmap {

inline constexpr int64_t kMs = 1'000'000;                 // nanoseconds per millisecond
inline constexpr double kDeg = std::numbers::pi / 180.0;  // radians per degree

}  // namespace semmap
