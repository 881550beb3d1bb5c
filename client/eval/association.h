// Timestamp handling of the TUM RGB-D benchmark tools (associate.py, evaluate_ate.py,
// evaluate_rpe.py), reproduced bit for bit so that `semmap eval` pairs exactly the poses the
// published tools pair.
//
// Why not AssociateStamps (client/datasets/stamp_association.h)? Its rule is the same greedy,
// one-to-one, smallest-|dt|-first rule, but evaluated exactly on int64 nanoseconds. The TUM
// scripts evaluate it on Python floats: stamps are float("1341841873.4151") (doubles with
// ~2.4e-7 s resolution at today's Unix times), |a - b| is a rounded double and compared with
// float("0.02"). The two rules pick different partners when two candidate differences are equal
// in exact arithmetic (a colour stamp at the midpoint of two 100 Hz ground-truth stamps: exact
// arithmetic breaks the tie by the earlier stamp, doubles by whichever rounding is smaller) and
// when |dt| is within a rounding error of max-diff. Both happen in real TUM sequences, and a
// different partner changes the ATE in the 6th decimal. So the evaluation keys every stamp by
// the double Python would have parsed, and keeps the file stamp (ns) alongside.
//
// Python dicts also collapse duplicate stamps (the last line wins); DeduplicateTum does the same.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "client/datasets/trajectory_io.h"

namespace semmap {

// The double that Python's float() yields for the stamp's decimal text (seconds): the
// correctly rounded value of stamp_ns / 1e9. Exact for any text with at most 9 decimals.
double TumStampSeconds(int64_t stamp_ns);

// A trajectory as the TUM scripts hold it: sorted by stamp, one pose per distinct double stamp
// (of poses whose stamps are equal as doubles, the last in file order is kept).
struct TumTrajectory {
  std::vector<StampedPose> poses;  // sorted by stamp
  std::vector<double> seconds;     // TumStampSeconds of each pose, ascending, distinct
  size_t duplicates_dropped = 0;   // poses of the input that a later pose replaced
};
TumTrajectory DeduplicateTum(const std::vector<StampedPose>& poses);

// One associated pair: indices into the first and the second sequence.
struct StampMatch {
  size_t first = 0;
  size_t second = 0;
};

// associate.py's rule: every (a, b) with |a - b| < max_difference_s (double arithmetic) is a
// candidate; candidates are taken in ascending (|a - b|, a, b) order, each stamp at most once.
// Inputs are ascending and distinct (TumTrajectory::seconds). The result is sorted by `first`.
std::vector<StampMatch> AssociateTum(const std::vector<double>& first,
                                     const std::vector<double>& second, double max_difference_s);

// evaluate_rpe.py's find_closest_index: a binary search over the ascending `values` that keeps
// the closest value it visits (the first visited wins a tie; values[0] is visited first).
// `values` must not be empty.
size_t FindClosestIndexTum(const std::vector<double>& values, double target);

}  // namespace semmap
