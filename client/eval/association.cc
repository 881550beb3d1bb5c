#include "client/eval/association.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <numeric>
#include <tuple>

namespace semmap {

double TumStampSeconds(int64_t stamp_ns) {
  constexpr int64_t kExactInDouble = int64_t{1} << 53;
  if (stamp_ns > -kExactInDouble && stamp_ns < kExactInDouble) {
    // Both operands are exact, and IEEE division rounds the exact quotient correctly.
    return static_cast<double>(stamp_ns) / 1e9;
  }
  // Larger (Unix-time) stamps: write the exact decimal value and let from_chars round it
  // correctly, as Python's float() does with the file's text.
  const uint64_t magnitude = stamp_ns < 0 ? uint64_t{0} - static_cast<uint64_t>(stamp_ns)
                                          : static_cast<uint64_t>(stamp_ns);
  char text[48];
  char* p = text;
  if (stamp_ns < 0) *p++ = '-';
  p = std::to_chars(p, text + sizeof(text), magnitude / 1'000'000'000).ptr;
  *p++ = '.';
  const uint64_t fraction = magnitude % 1'000'000'000;
  for (uint64_t unit = 100'000'000; unit > 0; unit /= 10)
    *p++ = static_cast<char>('0' + (fraction / unit) % 10);
  double seconds = 0;
  std::from_chars(text, p, seconds);
  return seconds;
}

TumTrajectory DeduplicateTum(const std::vector<StampedPose>& poses) {
  std::vector<double> seconds(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) seconds[i] = TumStampSeconds(poses[i].stamp_ns);
  std::vector<size_t> order(poses.size());
  std::iota(order.begin(), order.end(), size_t{0});
  // Stable: equal stamps stay in file order, so the last of each run is the one a Python dict
  // built from the file keeps.
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return seconds[a] < seconds[b]; });
  TumTrajectory out;
  out.poses.reserve(poses.size());
  out.seconds.reserve(poses.size());
  for (size_t k = 0; k < order.size(); ++k) {
    const size_t i = order[k];
    if (k + 1 < order.size() && seconds[order[k + 1]] == seconds[i]) {
      ++out.duplicates_dropped;
      continue;
    }
    out.poses.push_back(poses[i]);
    out.seconds.push_back(seconds[i]);
  }
  return out;
}

std::vector<StampMatch> AssociateTum(const std::vector<double>& first,
                                     const std::vector<double>& second, double max_difference_s) {
  struct Candidate {
    double difference;
    size_t first;
    size_t second;
  };
  std::vector<Candidate> candidates;
  // In exact arithmetic the partners of `a` lie in (a - max, a + max); the rounded test below
  // decides, so scan a window twice as wide (rounding moves the bound by ulps only).
  const double window = 2 * max_difference_s;
  for (size_t i = 0; i < first.size(); ++i) {
    const double a = first[i];
    auto it = std::lower_bound(second.begin(), second.end(), a - window);
    for (; it != second.end() && *it <= a + window; ++it) {
      const double difference = std::abs(a - *it);
      if (difference < max_difference_s) {
        candidates.push_back({difference, i, static_cast<size_t>(it - second.begin())});
      }
    }
  }
  // (difference, a, b) as Python sorts its tuples; a and b are distinct, so the order is total.
  std::sort(candidates.begin(), candidates.end(), [&](const Candidate& x, const Candidate& y) {
    return std::tie(x.difference, first[x.first], second[x.second]) <
           std::tie(y.difference, first[y.first], second[y.second]);
  });
  std::vector<bool> first_used(first.size(), false);
  std::vector<bool> second_used(second.size(), false);
  std::vector<StampMatch> matches;
  for (const Candidate& c : candidates) {
    if (first_used[c.first] || second_used[c.second]) continue;
    first_used[c.first] = true;
    second_used[c.second] = true;
    matches.push_back({c.first, c.second});
  }
  std::sort(matches.begin(), matches.end(),
            [](const StampMatch& x, const StampMatch& y) { return x.first < y.first; });
  return matches;
}

size_t FindClosestIndexTum(const std::vector<double>& values, double target) {
  size_t begin = 0;
  size_t end = values.size();
  size_t best = 0;
  double best_difference = std::abs(values[0] - target);
  while (begin < end) {
    const size_t middle = (begin + end) / 2;
    const double difference = std::abs(values[middle] - target);
    if (difference < best_difference) {
      best_difference = difference;
      best = middle;
    }
    if (values[middle] == target) return middle;
    if (values[middle] > target) {
      end = middle;
    } else {
      begin = middle + 1;
    }
  }
  return best;
}

}  // namespace semmap
