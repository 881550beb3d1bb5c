// RGB-D bundle adjustment (Ceres, Levenberg-Marquardt with the points eliminated by the Schur
// complement): keyframe poses and map points refined together from every observation of a
// point in a keyframe. Each observation has a reprojection residual and, where the keyframe
// measured depth at the keypoint, an inverse-depth residual: the same camera model and error
// terms as tracking's motion-only refinement (core/odometry/rgbd_refiner.h), so the map the
// tracker follows and the map BA refines agree on what a good fit is. Robust first (Huber),
// then outlier observations are removed by a chi-square gate and the rest solved without the
// robust loss (as ORB-SLAM2's LocalBundleAdjustment). Used for the local window after each
// keyframe and for the optional final BA at the end of a session; which keyframes are free
// and which are fixed is the caller's choice. Relative-pose constraints between keyframes (loop
// edges of the pose graph) can be added: a loop the pose graph closed stays closed while the
// points of both sides, which no observation ties together, are refined.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/camera.h"
#include "common/status.h"
#include "core/slam/pose_graph.h"

namespace semmap {

struct BundleAdjustmentOptions {
  // Inverse-depth sigma (1/metres) of a depth measurement (RgbdRefinerOptions' default).
  double inverse_depth_sigma = 3e-3;
  bool use_depth = true;
  int robust_iterations = 5;   // LM steps with the Huber loss, before outliers are removed
  int refine_iterations = 10;  // LM steps on the inliers, without the robust loss (0: skip)
  double chi2_2dof = 5.991;    // 95 % inlier gates: reprojection only ...
  double chi2_3dof = 7.815;    // ... and with the depth term
  // Observations whose point is closer than this to the camera (or behind it) are outliers.
  double min_depth_m = 0.05;
  // Wall-clock bound for each of the two solves (Ceres stops with the best solution so far);
  // 0: unbounded.
  double max_solve_seconds = 0;
  int num_threads = 1;
  // Problems with up to this many keyframes solve the Schur complement (the reduced camera
  // system) densely: at local-window sizes that is faster than a sparse factorisation, whose
  // symbolic analysis is redone on every solve (ICL kt2: 30 instead of 41 of 88 local BA runs
  // stopped at their 50 ms bound). Larger ones (a final BA) stay sparse.
  int dense_schur_max_keyframes = 64;
  // Huber scale (in sigmas) of the pose constraints, as the pose graph's loop_loss_scale.
  double pose_constraint_loss_scale = 1.0;

  Status Validate() const;  // INVALID_ARGUMENT naming the field
};

struct BundleAdjustmentKeyframe {
  int64_t id = 0;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  CameraCalibration camera;  // pinhole part only: observations are undistorted pixels
  bool fixed = false;        // held constant (none fixed: the first keyframe is)
};

struct BundleAdjustmentPoint {
  int64_t id = 0;
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  bool fixed = false;
};

struct BundleAdjustmentObservation {
  int64_t keyframe_id = 0;
  int64_t point_id = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // undistorted
  double pixel_sigma = 1.0;
  double inverse_depth = 0;  // 1 / measured depth at the keypoint; 0 when none
};

struct BundleAdjustmentResult {
  // Every keyframe and point, input order (fixed ones unchanged; a point left out because its
  // inlier observations do not determine it, too).
  std::vector<std::pair<int64_t, Eigen::Isometry3d>> T_world_keyframe;
  std::vector<std::pair<int64_t, Eigen::Vector3d>> position_world;
  std::vector<bool> outlier;  // per observation, after the final classification
  int num_outliers = 0;
  int num_points_optimised = 0;  // free points with enough inlier observations to solve for
  double initial_cost = 0, final_cost = 0;  // of the robust solve and of the final one
  int iterations = 0;
  double solve_ms = 0;
  bool hit_time_limit = false;
  std::string report;  // the final solve's Ceres BriefReport
};

// INVALID_ARGUMENT: bad options, duplicate ids, an observation naming an unknown keyframe or
// point, non-finite input, rotations that are not orthonormal, a non-positive pixel sigma or a
// negative inverse depth, an invalid calibration. FAILED_PRECONDITION when Ceres produces no
// usable solution. A free point is solved for only when its inlier observations determine it
// (one with depth, or two): otherwise it keeps its position and its observations still count
// for classification, not for the solve.
// `pose_constraints` are pose-graph edges whose node ids are keyframe ids (robust, with
// pose_constraint_loss_scale; never classified as outliers); INVALID_ARGUMENT for one naming an
// unknown keyframe, the same keyframe twice, or invalid pose or information.
StatusOr<BundleAdjustmentResult> BundleAdjust(
    const std::vector<BundleAdjustmentKeyframe>& keyframes,
    const std::vector<BundleAdjustmentPoint>& points,
    const std::vector<BundleAdjustmentObservation>& observations,
    const BundleAdjustmentOptions& options,
    const std::vector<PoseGraphEdge>& pose_constraints = {});

// Squared whitened error of one observation at the given pose and point (reprojection, plus
// the inverse-depth term when the observation has depth and use_depth), and whether the point
// is in front of the camera (depth >= min_depth_m). What the inlier gates are applied to.
struct ObservationError {
  double chi2 = 0;
  bool with_depth = false;
  bool in_front = false;
};
ObservationError EvaluateObservation(const BundleAdjustmentObservation& observation,
                                     const Eigen::Isometry3d& T_world_camera,
                                     const CameraCalibration& camera,
                                     const Eigen::Vector3d& position_world,
                                     const BundleAdjustmentOptions& options);

}  // namespace semmap
