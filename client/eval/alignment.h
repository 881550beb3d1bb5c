// Closed-form alignment of two associated point sets (Horn 1987 / Umeyama 1991), as the TUM
// benchmark's evaluate_ate.py aligns the estimate to the ground truth.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "common/status.h"

namespace semmap {

// p_target ~= scale * rotation * p_source + translation.
struct Alignment {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double scale = 1.0;

  Eigen::Vector3d Apply(const Eigen::Vector3d& p) const {
    return scale * (rotation * p) + translation;
  }
  // The pose seen from the target frame: rotation applied to the orientation, the position
  // mapped by Apply.
  Eigen::Isometry3d Apply(const Eigen::Isometry3d& T) const;
};

// Least-squares rigid (or, with `with_scale`, similarity) transform taking `source` onto
// `target` (same length, point i associated with point i):
//   rotation = U S V^T from the SVD U D V^T of sum_i (t_i - t_mean)(s_i - s_mean)^T, with
//   S = diag(1, 1, -1) when det(U) det(V) < 0 (never a reflection);
//   scale = sum_i (t_i - t_mean) . R (s_i - s_mean) / sum_i |s_i - s_mean|^2 (Umeyama's);
//   translation = t_mean - scale R s_mean.
// Errors: INVALID_ARGUMENT for fewer than 3 points or different lengths; FAILED_PRECONDITION
// when the alignment is not unique enough to define per-point errors: a point set that does
// not move, point sets whose spreads are uncorrelated, or a cross-covariance of rank 1 while
// neither set is collinear (a rotation about the common axis would change the errors).
// Collinear trajectories (straight-line motion) are fine: every optimal alignment gives them the
// same errors.
StatusOr<Alignment> AlignPoints(const std::vector<Eigen::Vector3d>& source,
                                const std::vector<Eigen::Vector3d>& target, bool with_scale);

}  // namespace semmap
