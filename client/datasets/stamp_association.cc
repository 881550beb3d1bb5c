#include "client/datasets/stamp_association.h"

#include <algorithm>
#include <iterator>
#include <numeric>
#include <queue>
#include <set>
#include <tuple>

#include "common/time_util.h"

namespace semmap {
namespace {

// One a-stamp's best remaining partner, ordered as associate.py sorts its candidate pairs:
// difference, then a's stamp, b's stamp, then the indices (a stable order for equal stamps).
struct Candidate {
  uint64_t difference;
  int64_t a_stamp;
  int64_t b_stamp;
  size_t a;
  size_t b;
  size_t group;  // b's stamp group

  auto Key() const { return std::tie(difference, a_stamp, b_stamp, a, b); }
  // std::priority_queue is a max-heap: "greater" puts the smallest key on top.
  bool operator>(const Candidate& other) const { return Key() > other.Key(); }
};

}  // namespace

std::vector<std::optional<size_t>> AssociateStamps(const std::vector<int64_t>& a,
                                                   const std::vector<int64_t>& b,
                                                   int64_t max_difference_ns) {
  std::vector<std::optional<size_t>> partner(a.size());
  if (a.empty() || b.empty() || max_difference_ns <= 0) return partner;
  const auto max_difference = static_cast<uint64_t>(max_difference_ns);

  // Accepting the smallest remaining candidate pair again and again is what associate.py's
  // greedy pass over all sorted pairs does, without listing the pairs: those grow with the
  // product of the list lengths (stamps 1 ns apart put every pair in the window), this with
  // their sum. b's indices grouped by stamp, groups in stamp order; within a group indices
  // ascend, and the smallest unused one is always the one taken, so a cursor per group marks
  // what is used.
  std::vector<size_t> b_order(b.size());
  std::iota(b_order.begin(), b_order.end(), size_t{0});
  std::stable_sort(b_order.begin(), b_order.end(), [&](size_t i, size_t j) { return b[i] < b[j]; });
  std::vector<int64_t> group_stamp;
  std::vector<size_t> group_begin;  // into b_order; group g is [group_begin[g], group_begin[g+1])
  for (size_t k = 0; k < b_order.size(); ++k) {
    if (k == 0 || b[b_order[k]] != group_stamp.back()) {
      group_stamp.push_back(b[b_order[k]]);
      group_begin.push_back(k);
    }
  }
  group_begin.push_back(b_order.size());
  std::vector<size_t> cursor(group_begin.begin(), group_begin.end() - 1);
  std::set<size_t> open;  // groups with an unused index
  for (size_t g = 0; g < group_stamp.size(); ++g) open.insert(g);

  // The best unused partner of a[i]: the nearest open group at or below its stamp or above it
  // (the lower one on a tie: the earlier b stamp), its smallest unused index.
  auto best = [&](size_t i) -> std::optional<Candidate> {
    const auto above_it = std::upper_bound(group_stamp.begin(), group_stamp.end(), a[i]);
    const size_t first_above = static_cast<size_t>(above_it - group_stamp.begin());
    const auto upper = open.lower_bound(first_above);
    std::optional<size_t> group;
    if (upper != open.begin()) group = *std::prev(upper);
    if (upper != open.end() && (!group || StampDistanceNs(group_stamp[*upper], a[i]) <
                                              StampDistanceNs(group_stamp[*group], a[i]))) {
      group = *upper;
    }
    if (!group) return std::nullopt;
    const uint64_t difference = StampDistanceNs(group_stamp[*group], a[i]);
    if (difference >= max_difference) return std::nullopt;
    return Candidate{difference, a[i], group_stamp[*group], i, b_order[cursor[*group]], *group};
  };

  std::priority_queue<Candidate, std::vector<Candidate>, std::greater<>> heap;
  for (size_t i = 0; i < a.size(); ++i) {
    if (const std::optional<Candidate> c = best(i)) heap.push(*c);
  }
  // Each a's entry is its best partner when it was computed; partners are only ever used up,
  // never added, so an entry whose b is still unused is still that a's best, and the smallest
  // such entry is the smallest remaining pair.
  while (!heap.empty() && !open.empty()) {
    const Candidate c = heap.top();
    heap.pop();
    const size_t g = c.group;
    const bool b_unused = cursor[g] < group_begin[g + 1] && b_order[cursor[g]] == c.b;
    if (!b_unused) {
      if (const std::optional<Candidate> next = best(c.a)) heap.push(*next);
      continue;
    }
    partner[c.a] = c.b;
    if (++cursor[g] == group_begin[g + 1]) open.erase(g);
  }
  return partner;
}

}  // namespace semmap
