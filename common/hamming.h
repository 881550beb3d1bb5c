// Hamming distance between binary descriptors (ORB, BRIEF, AKAZE-MLDB): the metric of
// descriptor matching (core/odometry) and of the bag-of-words vocabulary (core/slam).
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>

// Without -mpopcnt (the x86-64 baseline) std::popcount is a dozen instructions; the loops that
// compute many distances get a POPCNT clone chosen at load time (Transform 3x faster). Put it on
// the function that holds the loop, so that the inlined HammingDistance gets POPCNT.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__ELF__)
#define SEMMAP_POPCNT_CLONES __attribute__((target_clones("popcnt", "default")))
#else
#define SEMMAP_POPCNT_CLONES
#endif

namespace semmap {

// Number of differing bits between two descriptors of `bytes` bytes each. With a constant
// `bytes` (32 for ORB) the loop unrolls to straight-line code.
inline int HammingDistance(const uint8_t* a, const uint8_t* b, int bytes) {
  int distance = 0;
  int i = 0;
  for (; i + 8 <= bytes; i += 8) {
    uint64_t x = 0, y = 0;
    std::memcpy(&x, a + i, 8);  // memcpy: descriptor rows need not be 8-byte aligned
    std::memcpy(&y, b + i, 8);
    distance += std::popcount(x ^ y);
  }
  for (; i < bytes; ++i) distance += std::popcount(static_cast<uint8_t>(a[i] ^ b[i]));
  return distance;
}

// Index of the nearest of `count` (>= 1) centres stored contiguously at `centres` (ties: the
// lowest index); its distance goes to `*distance` when that is not null.
int NearestCentre(const uint8_t* x, const uint8_t* centres, int count, int bytes,
                  int* distance = nullptr);

}  // namespace semmap
