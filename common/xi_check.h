// The seed's neighbour check, shared by loop verification and object recognition: xi = N_c /
// N_n, N_c the support of a match in this keyframe (loop: PnP inliers against the candidate;
// object: good matches of the object), N_n the most support in any one neighbouring keyframe.
// A real revisit or object is seen from the neighbours too, with about as much support
// (xi ~ 1); a chance match, a transient picture (a screen, a page held up for a moment) or a
// perceptual alias that only this view lines up with is an isolated spike (xi >> 1) and is
// rejected. The best neighbour, not the mean: the view may be leaving the scene on one side.
//
// Edge cases:
//   - no neighbours at all (a session's first or only keyframe): accepted, xi reported 0
//     ("not computed"), because rejecting would make anything seen only there unfindable and
//     the detection has already passed the geometric check; a caller that prefers to wait
//     passes allow_without_neighbours = false and re-checks when neighbours exist;
//   - N_n = 0 with N_c > 0: xi = +infinity, rejected (no neighbour sees it at all);
//   - N_c = 0: xi = 0, accepted (nothing to reject; neither caller gets this far with it);
//   - xi exactly max_xi: accepted (reject only when xi > max_xi).
// Negative counts are read as 0.
#pragma once

#include <string_view>
#include <vector>

namespace semmap {

enum class XiVerdict { kAccepted, kAcceptedWithoutNeighbours, kRejected, kNoNeighbours };

// "accepted", "accepted without neighbours", "xi too high", "no neighbours".
std::string_view XiVerdictName(XiVerdict verdict);

struct XiDecision {
  XiVerdict verdict = XiVerdict::kAccepted;
  bool accepted() const {
    return verdict == XiVerdict::kAccepted || verdict == XiVerdict::kAcceptedWithoutNeighbours;
  }
  double xi = 0;  // N_c / N_n; +inf when N_n = 0 < N_c; 0 without neighbours or with N_c = 0
  int n_c = 0;
  int n_n = 0;  // the best neighbour's count (0 without neighbours)
};

// `neighbour_counts`: good matches of the same object type in each neighbouring keyframe.
// kNoNeighbours (not accepted) only when there are none and allow_without_neighbours is false.
XiDecision CheckXi(int n_c, const std::vector<int>& neighbour_counts, double max_xi,
                   bool allow_without_neighbours = true);

}  // namespace semmap
