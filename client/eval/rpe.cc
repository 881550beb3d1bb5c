#include "client/eval/rpe.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "client/eval/association.h"

namespace semmap {
namespace {

// numpy.median of the consecutive differences of ascending stamps.
double MedianInterval(const std::vector<double>& seconds) {
  std::vector<double> intervals(seconds.size() - 1);
  for (size_t i = 0; i + 1 < seconds.size(); ++i) intervals[i] = seconds[i + 1] - seconds[i];
  std::sort(intervals.begin(), intervals.end());
  const size_t half = intervals.size() / 2;
  return intervals.size() % 2 == 1 ? intervals[half]
                                   : 0.5 * (intervals[half - 1] + intervals[half]);
}

// The script's overlap check: every estimate stamp, sent to its closest ground-truth stamp and
// back to the closest estimate stamp, must reach at least two distinct estimate stamps.
bool EnoughOverlap(const std::vector<double>& gt, const std::vector<double>& est) {
  size_t first_return = 0;
  bool have_first = false;
  for (double t : est) {
    const size_t back = FindClosestIndexTum(est, gt[FindClosestIndexTum(gt, t)]);
    if (!have_first) {
      first_return = back;
      have_first = true;
    } else if (back != first_return) {
      return true;
    }
  }
  return false;
}

}  // namespace

Status RpeOptions::Validate() const {
  if (!std::isfinite(delta) || !(delta > 0)) {
    return InvalidArgumentError("delta must be a positive number, got " + std::to_string(delta));
  }
  if (max_difference_s && (!std::isfinite(*max_difference_s) || !(*max_difference_s > 0))) {
    return InvalidArgumentError("max difference must be a positive number of seconds, got " +
                                std::to_string(*max_difference_s));
  }
  return OkStatus();
}

StatusOr<RpeResult> ComputeRpe(const std::vector<StampedPose>& ground_truth,
                               const std::vector<StampedPose>& estimate,
                               const RpeOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  const TumTrajectory gt = DeduplicateTum(ground_truth);
  const TumTrajectory est = DeduplicateTum(estimate);
  if (gt.poses.size() < 2 || est.poses.size() < 2) {
    return InvalidArgumentError("RPE needs at least 2 poses in each trajectory (ground truth " +
                                std::to_string(gt.poses.size()) + ", estimate " +
                                std::to_string(est.poses.size()) + ")");
  }
  if (!EnoughOverlap(gt.seconds, est.seconds)) {
    return InvalidArgumentError(
        "the stamps of the ground truth and the estimate hardly overlap: are these the right "
        "files?");
  }

  const size_t n = est.poses.size();
  std::vector<double> index;
  if (options.unit == RpeDeltaUnit::kSeconds) {
    index = est.seconds;
  } else {
    index.resize(n);
    for (size_t i = 0; i < n; ++i) index[i] = static_cast<double>(i);
  }

  const double median_interval = MedianInterval(gt.seconds);
  RpeResult result;
  result.max_difference_s = options.max_difference_s.value_or(2 * median_interval);
  result.gt_duplicates_dropped = gt.duplicates_dropped;
  result.est_duplicates_dropped = est.duplicates_dropped;
  const auto too_far = [&](double difference) {
    return options.max_difference_s ? !(difference < *options.max_difference_s)
                                    : difference > 2 * median_interval;
  };

  std::vector<double> translation_errors;
  std::vector<double> rotation_errors_rad;
  for (size_t i = 0; i < n; ++i) {
    const size_t j = FindClosestIndexTum(index, index[i] + options.delta);
    if (j == n - 1) continue;
    const size_t gi = FindClosestIndexTum(gt.seconds, est.seconds[i]);
    const size_t gj = FindClosestIndexTum(gt.seconds, est.seconds[j]);
    if (too_far(std::abs(gt.seconds[gi] - est.seconds[i])) ||
        too_far(std::abs(gt.seconds[gj] - est.seconds[j]))) {
      continue;
    }
    const Eigen::Isometry3d A = est.poses[i].T_world_camera.inverse() * est.poses[j].T_world_camera;
    const Eigen::Isometry3d B = gt.poses[gi].T_world_camera.inverse() * gt.poses[gj].T_world_camera;
    const Eigen::Isometry3d E = A * B.inverse();
    RpePair pair;
    pair.est_stamp_ns[0] = est.poses[i].stamp_ns;
    pair.est_stamp_ns[1] = est.poses[j].stamp_ns;
    pair.gt_stamp_ns[0] = gt.poses[gi].stamp_ns;
    pair.gt_stamp_ns[1] = gt.poses[gj].stamp_ns;
    pair.translation_error_m = E.translation().norm();
    const double c = std::clamp((E.linear().trace() - 1.0) / 2.0, -1.0, 1.0);
    const double angle_rad = std::acos(c);
    pair.rotation_error_deg = angle_rad * 180.0 / std::numbers::pi;
    translation_errors.push_back(pair.translation_error_m);
    rotation_errors_rad.push_back(angle_rad);
    result.pairs.push_back(pair);
  }
  if (result.pairs.size() < 2) {
    return InvalidArgumentError("only " + std::to_string(result.pairs.size()) +
                                " pose pairs could be evaluated (at least 2 are needed): is delta "
                                "shorter than the trajectory, and do the stamps match?");
  }
  SEMMAP_ASSIGN_OR_RETURN(result.translation_m, ComputeStatistics(translation_errors));
  SEMMAP_ASSIGN_OR_RETURN(const ErrorStatistics rotation_rad,
                          ComputeStatistics(rotation_errors_rad));
  // Statistics in radians, then converted, as the script prints them.
  result.rotation_deg = rotation_rad.Scaled(180.0 / std::numbers::pi);
  return result;
}

}  // namespace semmap
