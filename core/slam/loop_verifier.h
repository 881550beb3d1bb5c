// Verification of a loop-closure candidate: geometric (PnP-RANSAC of the query's keypoints
// against the candidate's 3D points, enough inliers, low reprojection error) and by the ratio
// xi = N_c / N_n of the query's geometrically consistent matches with the candidate (N_c) to
// those with the candidate's neighbouring keyframes (N_n). A real revisit is seen by the
// candidate's neighbours too; a candidate that matches much better than all its neighbours is
// an isolated spike of similarity (a chance match) and is rejected. xi does not catch a
// perceptual alias (a repeated poster) that the candidate's neighbours see as well: the
// ratio is then the same as for a true revisit; only the lower absolute N_c differs.
// xi ~ 1 needs neighbours that overlap the candidate closely (about one default keyframe
// step: 0.1 m / 5 degrees); at twice that spacing true revisits reach xi 1.4-2. Which
// keyframes are the neighbours is the caller's choice (SlamBackend: the candidate's session
// neighbours and other sessions' keyframes at the same view, SlamBackendOptions::
// xi_view_neighbours).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string_view>
#include <utility>
#include <vector>

#include "common/camera.h"
#include "common/status.h"
#include "core/odometry/feature_matcher.h"
#include "core/odometry/motion_estimator.h"
#include "core/sensor/frame_features.h"

namespace semmap {

struct LoopVerifierOptions {
  FeatureMatcherOptions matcher;  // descriptor matching (ratio + cross check)
  MotionEstimatorOptions motion;  // PnP-RANSAC + refinement, for the candidate and neighbours
  int min_inliers = 40;           // geometric: N_c must reach this (>= motion.min_inliers)
  double max_rms_px = 2.0;        // geometric: reprojection RMS over the inliers
  double min_inlier_ratio = 0.3;  // inliers / matches of the candidate solve
  double max_xi = 1.25;           // reject when N_c / N_n > max_xi
  bool allow_without_neighbours = false;  // accept on geometry alone when no neighbours given

  Status Validate() const;
};

enum class LoopDecision { kAccepted, kTooFewMatches, kGeometryFailed, kXiTooHigh, kNoNeighbours };

// "accepted", "too few matches", "geometry failed", "xi too high", "no neighbours".
std::string_view LoopDecisionName(LoopDecision d);

struct LoopVerification {
  LoopDecision decision = LoopDecision::kTooFewMatches;
  bool accepted() const { return decision == LoopDecision::kAccepted; }
  int num_matches = 0;        // descriptor matches with the candidate (its keypoints with depth)
  int candidate_inliers = 0;  // N_c (0 when the solve fails)
  int neighbour_inliers = 0;  // N_n: the most inliers of any one neighbour
  // Inliers of each neighbour's solve, in the order given (empty when they were not needed:
  // the candidate failed geometry, or there are no neighbours).
  std::vector<int> inliers_per_neighbour;
  double xi = 0;  // N_c / N_n: infinity when N_n == 0, 0 when not computed (as above)
  double rms_px = 0;
  // The query camera in the candidate's frame, and the information of the error e in
  // T_candidate_query * exp(e) as MotionEstimate::information (zero when the solve failed).
  Eigen::Isometry3d T_candidate_query = Eigen::Isometry3d::Identity();
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  // The candidate solve's inlier correspondences: (query keypoint, candidate keypoint). The
  // back end fuses the map points on either side of an accepted loop through them.
  std::vector<std::pair<int, int>> inlier_matches;
};

// `query`, `candidate`, `neighbours[i]`: features of keyframes of one camera (3D points in each
// keyframe's own frame). Only keypoints with depth of the candidate and of the neighbours
// enter the solves; the query needs no depth. The neighbours are solved only when the
// candidate passes the geometric checks. INVALID_ARGUMENT for bad options, a null neighbour,
// features whose per-keypoint arrays disagree in size, or mismatched descriptor types;
// INTERNAL when OpenCV fails. Rejections are results, not errors.
StatusOr<LoopVerification> VerifyLoopCandidate(const FrameFeatures& query,
                                               const FrameFeatures& candidate,
                                               const std::vector<const FrameFeatures*>& neighbours,
                                               const CameraCalibration& camera,
                                               const LoopVerifierOptions& options);

// The decision rules alone (exposed for tests), each kAccepted when its check passes.
// Geometry: kTooFewMatches below max(min_inliers, motion.min_matches) matches (the solve could
// not reach min_inliers), kGeometryFailed when inliers < min_inliers, rms > max_rms_px or
// inliers < min_inlier_ratio * matches.
LoopDecision DecideGeometry(int num_matches, int candidate_inliers, double rms_px,
                            const LoopVerifierOptions& options);
// xi (CheckXi, common/xi_check.h): kNoNeighbours when num_neighbours == 0 (kAccepted with
// allow_without_neighbours), kXiTooHigh when n_c / n_n > max_xi (a ratio exactly at
// max_xi is accepted).
LoopDecision DecideXi(int candidate_inliers, int neighbour_inliers, int num_neighbours,
                      const LoopVerifierOptions& options);

}  // namespace semmap
