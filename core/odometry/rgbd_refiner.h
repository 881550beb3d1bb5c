// Motion-only refinement of a camera pose from 3D points and their RGB-D observations: the
// reprojection error of each point and, where the current frame measured depth at the
// keypoint, an inverse-depth error (the RGB-D counterpart of a stereo camera's right-image
// coordinate). Residuals are whitened by per-observation sigmas, robustified with Huber, and
// outliers are reclassified between rounds by a chi-square test (as ORB-SLAM2's
// PoseOptimization).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "common/camera.h"
#include "common/status.h"

namespace semmap {

struct RgbdRefinerOptions {
  // Inverse-depth sigma (1/metres) of a depth measurement and of the point it is compared with.
  // Structured-light depth has sigma_z ~ 1.5e-3 z^2, i.e. a constant inverse-depth sigma.
  double inverse_depth_sigma = 3e-3;
  bool use_depth = true;
  int rounds = 3;            // reclassification rounds (fewer once one changes no inlier)
  int iterations = 8;        // Levenberg-Marquardt steps per round
  double chi2_2dof = 5.991;  // 95% inlier gates: reprojection only ...
  double chi2_3dof = 7.815;  // ... and with the depth term

  Status Validate() const;
};

struct RgbdObservation {
  Eigen::Vector3d point;  // in the reference frame (world for a map)
  Eigen::Vector2d pixel;  // undistorted pixel in the current image
  double pixel_sigma = 1.0;
  double inverse_depth = 0;  // 1 / measured depth at the pixel; 0 when none
};

struct RgbdRefinement {
  Eigen::Isometry3d T_current_reference = Eigen::Isometry3d::Identity();
  std::vector<bool> inlier;  // per observation, after the last round
  int num_inliers = 0;
  // Information of the error delta in exp(delta) * T_current_reference over the final inliers
  // (equivalently of xi in T_reference_current * exp(-xi)), delta = (translation, rotation) in
  // the current camera frame; same convention as MotionEstimate::information.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
};

// Always returns a finite pose (the start when nothing improves it).
RgbdRefinement RefinePoseRgbd(const std::vector<RgbdObservation>& observations,
                              const CameraCalibration& camera, const RgbdRefinerOptions& options,
                              const Eigen::Isometry3d& T_current_reference);

}  // namespace semmap
