#include "common/hamming.h"

#include <cstddef>

namespace semmap {

SEMMAP_POPCNT_CLONES int NearestCentre(const uint8_t* x, const uint8_t* centres, int count,
                                       int bytes, int* distance) {
  int best = 0, best_distance = HammingDistance(x, centres, bytes);
  for (int c = 1; c < count; ++c) {
    const int d =
        HammingDistance(x, centres + static_cast<size_t>(c) * static_cast<size_t>(bytes), bytes);
    if (d < best_distance) best_distance = d, best = c;
  }
  if (distance != nullptr) *distance = best_distance;
  return best;
}

}  // namespace semmap
