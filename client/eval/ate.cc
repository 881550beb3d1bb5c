#include "client/eval/ate.h"

#include <cmath>
#include <string>

#include "client/eval/association.h"

namespace semmap {

Status AteOptions::Validate() const {
  if (!std::isfinite(max_difference_s) || !(max_difference_s > 0)) {
    return InvalidArgumentError("max difference must be a positive number of seconds, got " +
                                std::to_string(max_difference_s));
  }
  return OkStatus();
}

StatusOr<AteResult> ComputeAte(const std::vector<StampedPose>& ground_truth,
                               const std::vector<StampedPose>& estimate,
                               const AteOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  TumTrajectory gt = DeduplicateTum(ground_truth);
  TumTrajectory est = DeduplicateTum(estimate);
  const std::vector<StampMatch> matches =
      AssociateTum(gt.seconds, est.seconds, options.max_difference_s);
  if (matches.size() < 3) {
    return InvalidArgumentError(
        "only " + std::to_string(matches.size()) + " ground-truth/estimate stamp pairs within " +
        std::to_string(options.max_difference_s) + " s (of " + std::to_string(gt.poses.size()) +
        " ground-truth and " + std::to_string(est.poses.size()) +
        " estimated poses); at least 3 are needed: are these the right files?");
  }

  std::vector<Eigen::Vector3d> gt_points(matches.size());
  std::vector<Eigen::Vector3d> est_points(matches.size());
  for (size_t k = 0; k < matches.size(); ++k) {
    gt_points[k] = gt.poses[matches[k].first].T_world_camera.translation();
    est_points[k] = est.poses[matches[k].second].T_world_camera.translation();
  }
  SEMMAP_ASSIGN_OR_RETURN(const Alignment alignment,
                          AlignPoints(est_points, gt_points, options.estimate_scale));

  AteResult result;
  result.alignment = alignment;
  result.scale_estimated = options.estimate_scale;
  result.pairs.resize(matches.size());
  std::vector<double> errors(matches.size());
  for (size_t k = 0; k < matches.size(); ++k) {
    AtePair& pair = result.pairs[k];
    pair.gt_stamp_ns = gt.poses[matches[k].first].stamp_ns;
    pair.est_stamp_ns = est.poses[matches[k].second].stamp_ns;
    pair.gt_position = gt_points[k];
    pair.est_position_aligned = alignment.Apply(est_points[k]);
    pair.error_m = (pair.est_position_aligned - pair.gt_position).norm();
    errors[k] = pair.error_m;
  }
  SEMMAP_ASSIGN_OR_RETURN(result.stats, ComputeStatistics(errors));

  result.aligned_estimate.reserve(est.poses.size());
  for (const StampedPose& pose : est.poses) {
    result.aligned_estimate.push_back({pose.stamp_ns, alignment.Apply(pose.T_world_camera)});
  }
  result.ground_truth = std::move(gt.poses);
  result.gt_duplicates_dropped = gt.duplicates_dropped;
  result.est_duplicates_dropped = est.duplicates_dropped;
  return result;
}

}  // namespace semmap
