// Absolute trajectory error with the semantics of the TUM RGB-D benchmark's evaluate_ate.py
// (Sturm et al., IROS 2012), run with its defaults (--offset 0, --scale 1):
//  1. each file becomes a dict stamp -> pose: poses whose stamps are equal as doubles collapse to
//     the last one in file order (see association.h);
//  2. ground-truth and estimate stamps are associated by associate.py's rule: every pair with
//     |t_gt - t_est| < max_difference_s is a candidate, candidates are accepted greedily by
//     smallest |dt| (ties: smaller gt stamp, then smaller est stamp), one-to-one, all in the
//     double arithmetic the script uses;
//  3. the associated estimate positions are aligned to the ground-truth positions by Horn's
//     closed form (rotation + translation; with estimate_scale, Umeyama's similarity as in the
//     widely used evaluate_ate_scale.py variant);
//  4. the error of a pair is |R p_est + t - p_gt| (times s for the similarity);
//  5. statistics as numpy: rmse, mean, median, population std, min, max (statistics.h).
// The script accepts 2 pairs; we require 3 (an alignment of 2 positions is not unique).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "client/datasets/trajectory_io.h"
#include "client/eval/alignment.h"
#include "client/eval/statistics.h"
#include "common/status.h"

namespace semmap {

struct AteOptions {
  double max_difference_s = 0.02;  // associate.py's --max_difference (strict: |dt| < this)
  bool estimate_scale = false;     // similarity instead of rigid alignment

  // INVALID_ARGUMENT unless max_difference_s is finite and > 0.
  Status Validate() const;
};

struct AtePair {
  int64_t gt_stamp_ns = 0;
  int64_t est_stamp_ns = 0;
  Eigen::Vector3d gt_position = Eigen::Vector3d::Zero();
  Eigen::Vector3d est_position_aligned = Eigen::Vector3d::Zero();
  double error_m = 0;
};

struct AteResult {
  Alignment alignment;           // maps estimate positions into the ground-truth frame
  bool scale_estimated = false;  // AteOptions::estimate_scale
  ErrorStatistics stats;         // over pairs[i].error_m, metres
  std::vector<AtePair> pairs;    // sorted by ground-truth stamp
  // Both trajectories as evaluated (sorted, duplicates dropped); the estimate is aligned.
  std::vector<StampedPose> ground_truth;
  std::vector<StampedPose> aligned_estimate;
  size_t gt_duplicates_dropped = 0;
  size_t est_duplicates_dropped = 0;
};

// INVALID_ARGUMENT for bad options or fewer than 3 associated pairs; FAILED_PRECONDITION for
// degenerate geometry (see AlignPoints). Never returns non-finite statistics.
StatusOr<AteResult> ComputeAte(const std::vector<StampedPose>& ground_truth,
                               const std::vector<StampedPose>& estimate,
                               const AteOptions& options = {});

}  // namespace semmap
