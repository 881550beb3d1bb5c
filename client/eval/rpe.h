// Relative pose error with the semantics of the TUM RGB-D benchmark's evaluate_rpe.py
// (Sturm et al., IROS 2012) in its fixed-delta mode, i.e. exactly what
//   evaluate_rpe.py GT EST --fixed_delta --delta D --delta_unit {s|f} --max_pairs 0
// computes (offset 0, scale 1). Precisely:
//  1. each file becomes a dict stamp -> pose (duplicate stamps: the last line wins), sorted by
//     stamp; stamps are compared as the doubles Python parses (association.h);
//  2. for every estimate pose i (sorted order), j = the estimate pose whose index value is
//     closest to index(i) + delta, where index is the stamp in seconds (unit s) or the position
//     in the sorted estimate (unit f), found with the script's find_closest_index. The pair
//     (i, j) is dropped when j is the LAST estimate pose (the script's end-of-sequence test;
//     note it also drops a pair that ends exactly on the last pose). j == i is kept (a delta
//     shorter than half the frame spacing yields zero-motion pairs, as in the script);
//  3. ALL such pairs are evaluated: no random sampling (the script samples 10000 pairs when there
//     are more unless --max_pairs 0 is given; we always evaluate all);
//  4. each estimate stamp is matched to the ground-truth pose with the closest stamp (not
//     one-to-one); a pair is skipped when either match is off by more than twice the median
//     ground-truth stamp interval (the script's rule, used when max_difference_s is unset) or,
//     when max_difference_s is set, by max_difference_s or more;
//  5. with A = est_i^-1 est_j and B = gt_i^-1 gt_j, the error is E = A B^-1, which is what
//     the script evaluates (ominus(ominus(est_j, est_i), ominus(gt_j, gt_i))). The paper writes
//     E = B^-1 A; the rotation angle is the same, the translation norms differ when the relative
//     rotations of A and B differ. Translational error |t_E| (m), rotational error
//     arccos(clamp((trace R_E - 1) / 2)) reported in degrees;
//  6. fewer than 2 evaluated pairs is an error (the script's limit); statistics as numpy. The
//     script prints the rotational median in radians under a "deg" label: here every rotational
//     statistic is in degrees.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "client/datasets/trajectory_io.h"
#include "client/eval/statistics.h"
#include "common/status.h"

namespace semmap {

enum class RpeDeltaUnit { kSeconds, kFrames };

struct RpeOptions {
  double delta = 1.0;  // > 0, in `unit`
  RpeDeltaUnit unit = RpeDeltaUnit::kSeconds;
  // Unset: evaluate_rpe.py's rule (twice the median ground-truth interval, inclusive). Set:
  // a stamp matches its closest ground-truth stamp only when |dt| < max_difference_s.
  std::optional<double> max_difference_s;

  Status Validate() const;
};

struct RpePair {
  int64_t est_stamp_ns[2] = {0, 0};  // i, j
  int64_t gt_stamp_ns[2] = {0, 0};   // their closest ground-truth stamps
  double translation_error_m = 0;
  double rotation_error_deg = 0;
};

struct RpeResult {
  std::vector<RpePair> pairs;  // in estimate order of i
  ErrorStatistics translation_m;
  ErrorStatistics rotation_deg;
  double max_difference_s = 0;  // the stamp tolerance that was applied
  size_t gt_duplicates_dropped = 0;
  size_t est_duplicates_dropped = 0;
};

// INVALID_ARGUMENT for bad options, fewer than 2 poses in either trajectory, too little overlap
// or fewer than 2 evaluated pairs.
StatusOr<RpeResult> ComputeRpe(const std::vector<StampedPose>& ground_truth,
                               const std::vector<StampedPose>& estimate,
                               const RpeOptions& options = {});

}  // namespace semmap
