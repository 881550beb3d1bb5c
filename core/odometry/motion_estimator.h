// Relative camera motion from 3D points of a reference frame and their 2D observations in the
// current frame: PnP inside RANSAC, then motion-only Gauss-Newton on the reprojection error
// with Huber weights.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core/types.hpp>
#include <optional>
#include <vector>

#include "common/camera.h"
#include "common/status.h"

namespace semmap {

enum class PnpMethod { kEpnp, kSqpnp };

struct MotionEstimatorOptions {
  int min_matches = 20;  // fewer correspondences: FAILED_PRECONDITION, nothing estimated
  int min_inliers = 15;  // fewer inliers after refinement: FAILED_PRECONDITION
  PnpMethod method = PnpMethod::kSqpnp;
  double ransac_threshold_px = 3.0;  // reprojection error of a RANSAC inlier
  int ransac_iterations = 100;
  double ransac_confidence = 0.995;
  // Refinement: Huber loss with this scale (pixels), at most this many Gauss-Newton steps;
  // final inliers are the correspondences within ransac_threshold_px of the refined pose.
  double huber_px = 2.0;
  int refine_iterations = 10;
  double pixel_sigma = 1.0;  // image noise assumed for the information matrix

  Status Validate() const;
};

struct MotionEstimate {
  Eigen::Isometry3d T_reference_current = Eigen::Isometry3d::Identity();
  std::vector<int> inliers;  // indices into the correspondences, ascending
  // Information (inverse covariance) of the error xi in T_reference_current * exp(xi), xi =
  // (translation, rotation) in the current camera frame (metres, radians), from the final
  // normal equations over the inliers (J^T W J / pixel_sigma^2). Covariance is its inverse
  // (zero when the information is singular).
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  double rms_reprojection_px = 0;  // over the inliers
};

// `points_reference[i]` (metres, reference camera frame) is seen at `pixels_current[i]`
// (undistorted pixels of `camera`'s pinhole model). `T_reference_current_guess`, when given,
// seeds the refinement besides the RANSAC solution (the better of the two is kept).
// FAILED_PRECONDITION "too few matches (N < M)" below min_matches, or too few inliers;
// INVALID_ARGUMENT for mismatched sizes or bad options; INTERNAL when OpenCV fails. The pose
// returned is always finite.
StatusOr<MotionEstimate> EstimateMotion(
    const std::vector<Eigen::Vector3d>& points_reference,
    const std::vector<cv::Point2f>& pixels_current, const CameraCalibration& camera,
    const MotionEstimatorOptions& options,
    const std::optional<Eigen::Isometry3d>& T_reference_current_guess = std::nullopt);

// Motion-only refinement alone (exposed for tests): Gauss-Newton with Huber weights on all
// correspondences starting from T_current_reference; returns the refined pose.
Eigen::Isometry3d RefinePose(const std::vector<Eigen::Vector3d>& points_reference,
                             const std::vector<cv::Point2f>& pixels_current,
                             const CameraCalibration& camera, const MotionEstimatorOptions& options,
                             const Eigen::Isometry3d& T_current_reference,
                             Eigen::Matrix<double, 6, 6>* information = nullptr);

}  // namespace semmap
