#include "client/datasets/stamp_association.h"

#include <algorithm>
#include <numeric>
#include <tuple>

namespace semmap {
namespace {

struct Candidate {
  int64_t difference;
  size_t a;
  size_t b;
};

}  // namespace

std::vector<std::optional<size_t>> AssociateStamps(const std::vector<int64_t>& a,
                                                   const std::vector<int64_t>& b,
                                                   int64_t max_difference_ns) {
  // b's indices in stamp order, so each a-stamp finds its candidate window by binary search
  // instead of associate.py's all-pairs scan (quadratic on long sequences).
  std::vector<size_t> b_order(b.size());
  std::iota(b_order.begin(), b_order.end(), size_t{0});
  std::stable_sort(b_order.begin(), b_order.end(), [&](size_t i, size_t j) { return b[i] < b[j]; });

  std::vector<Candidate> candidates;
  for (size_t i = 0; i < a.size(); ++i) {
    auto it = std::upper_bound(b_order.begin(), b_order.end(), a[i] - max_difference_ns,
                               [&](int64_t stamp, size_t j) { return stamp < b[j]; });
    for (; it != b_order.end() && b[*it] < a[i] + max_difference_ns; ++it) {
      const int64_t d = b[*it] > a[i] ? b[*it] - a[i] : a[i] - b[*it];
      candidates.push_back({d, i, *it});
    }
  }
  std::sort(candidates.begin(), candidates.end(), [&](const Candidate& x, const Candidate& y) {
    return std::tie(x.difference, a[x.a], b[x.b], x.a, x.b) <
           std::tie(y.difference, a[y.a], b[y.b], y.a, y.b);
  });

  std::vector<std::optional<size_t>> partner(a.size());
  std::vector<bool> b_used(b.size(), false);
  for (const Candidate& c : candidates) {
    if (partner[c.a] || b_used[c.b]) continue;
    partner[c.a] = c.b;
    b_used[c.b] = true;
  }
  return partner;
}

}  // namespace semmap
