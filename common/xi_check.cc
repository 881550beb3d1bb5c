#include "common/xi_check.h"

#include <algorithm>
#include <limits>

namespace semmap {

std::string_view XiVerdictName(XiVerdict verdict) {
  switch (verdict) {
    case XiVerdict::kAccepted:
      return "accepted";
    case XiVerdict::kAcceptedWithoutNeighbours:
      return "accepted without neighbours";
    case XiVerdict::kRejected:
      return "xi too high";
    case XiVerdict::kNoNeighbours:
      return "no neighbours";
  }
  return "unknown";
}

XiDecision CheckXi(int n_c, const std::vector<int>& neighbour_counts, double max_xi,
                   bool allow_without_neighbours) {
  XiDecision d;
  d.n_c = std::max(0, n_c);
  if (neighbour_counts.empty()) {
    d.verdict =
        allow_without_neighbours ? XiVerdict::kAcceptedWithoutNeighbours : XiVerdict::kNoNeighbours;
    return d;
  }
  for (int n : neighbour_counts) d.n_n = std::max(d.n_n, n);
  if (d.n_c == 0) {
    d.xi = 0;
  } else if (d.n_n == 0) {
    d.xi = std::numeric_limits<double>::infinity();
  } else {
    d.xi = static_cast<double>(d.n_c) / static_cast<double>(d.n_n);
  }
  // The ratio itself is compared (not n_c > max_xi * n_n) so that the xi reported is the one
  // decided on; NaN max_xi cannot reach here through validated options, and would accept.
  d.verdict = d.xi > max_xi ? XiVerdict::kRejected : XiVerdict::kAccepted;
  return d;
}

}  // namespace semmap
