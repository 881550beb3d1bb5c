// associate.py's stamp association as the TUM script writes it: every pair within the
// threshold, sorted by (difference, a's stamp, b's stamp, indices), taken greedily. Quadratic:
// the reference that AssociateStamps is checked against on small inputs (unit test and fuzzer).
#pragma once

#include <algorithm>
#include <cstdint>
#include <optional>
#include <tuple>
#include <vector>

namespace semmap::testing {

inline std::vector<std::optional<size_t>> AssociateAllPairs(const std::vector<int64_t>& a,
                                                            const std::vector<int64_t>& b,
                                                            int64_t max) {
  std::vector<std::tuple<int64_t, int64_t, int64_t, size_t, size_t>> pairs;
  for (size_t i = 0; i < a.size(); ++i) {
    for (size_t j = 0; j < b.size(); ++j) {
      const int64_t d = a[i] > b[j] ? a[i] - b[j] : b[j] - a[i];
      if (d < max) pairs.emplace_back(d, a[i], b[j], i, j);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<std::optional<size_t>> partner(a.size());
  std::vector<bool> used(b.size(), false);
  for (const auto& [d, sa, sb, i, j] : pairs) {
    if (partner[i] || used[j]) continue;
    partner[i] = j;
    used[j] = true;
  }
  return partner;
}

}  // namespace semmap::testing
