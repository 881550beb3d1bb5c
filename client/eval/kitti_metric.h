// The KITTI odometry benchmark's metric, as its devkit (evaluate_odometry.cpp) computes it:
//  - path distances along the GROUND TRUTH, accumulated in single precision like the devkit;
//  - segments start at frames 0, 10, 20, ... (step_frames) and, for each length L of
//    100, 200, ..., 800 m, end at the first frame whose distance exceeds dist[first] + L
//    (start frames without such a frame contribute no segment of that length);
//  - per segment E = (est_first^-1 est_last)^-1 (gt_first^-1 gt_last),
//    t_err = |t_E| / L and r_err = acos(clamp((trace R_E - 1) / 2)) / L (radians per metre),
//    rounded to single precision where the devkit does;
//  - averages over all segments (single-precision sums in segment order, as the devkit's
//    stats.txt), and per length.
// Reported as t_rel = 100 t_err (%) and r_rel = r_err * 180/pi * 100 (deg / 100 m). The devkit
// prints its per-length table only for lengths with at least 3 segments; we report every length
// that has a segment, with its count. Poses are frame-indexed: both trajectories must have the
// same number of poses, pose i of one corresponding to pose i of the other.
#pragma once

#include <cstddef>
#include <vector>

#include "client/datasets/trajectory_io.h"
#include "common/status.h"

namespace semmap {

struct KittiOptions {
  std::vector<double> lengths_m = {100, 200, 300, 400, 500, 600, 700, 800};
  int step_frames = 10;

  Status Validate() const;
};

struct KittiSegment {
  int first_frame = 0;
  int last_frame = 0;
  float length_m = 0;
  float t_err = 0;  // translation error / length (fraction)
  float r_err = 0;  // rotation error / length (rad / m)
};

struct KittiLengthStats {
  double length_m = 0;
  size_t segments = 0;
  float t_err = 0;  // mean over this length's segments
  float r_err = 0;
  double t_rel_percent = 0;
  double r_rel_deg_per_100m = 0;
};

struct KittiResult {
  std::vector<KittiSegment> segments;        // in devkit order (first frame, then length)
  std::vector<KittiLengthStats> per_length;  // lengths with at least one segment
  float t_err = 0;                           // mean over all segments (fraction)
  float r_err = 0;                           // mean over all segments (rad / m)
  double t_rel_percent = 0;
  double r_rel_deg_per_100m = 0;
  double gt_path_length_m = 0;
};

// INVALID_ARGUMENT for bad options, no poses or different pose counts; FAILED_PRECONDITION when
// the ground-truth path is shorter than the shortest segment length (no segment at all).
StatusOr<KittiResult> ComputeKittiMetric(const std::vector<StampedPose>& ground_truth,
                                         const std::vector<StampedPose>& estimate,
                                         const KittiOptions& options = {});

}  // namespace semmap
