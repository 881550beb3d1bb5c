// The keyframe rule, all of it, for every session mode (the seed algorithm's keyframe step):
//  - the first frame of a map segment is a keyframe;
//  - a visual frame without depth of its own never is (it has no 3D points to add);
//  - a relocalised frame is (tracking goes on from there, not from the reference that failed);
//  - otherwise a frame becomes a keyframe when the norm of its motion since the last keyframe
//    exceeds min_motion (rotation counted at rotation_weight metres per radian) -- for known
//    poses and the learned VO's predicted motion (MONO) that alone decides -- or, when
//    tracked visually, when its inliers fall below min_inlier_fraction of those of the first
//    frame tracked against the current reference (the view is leaving the reference);
//  - but a visually tracked frame within min_motion of a keyframe the map already holds
//    (any session's, other than the reference: a revisit) does not become one by motion
//    (skip_mapped_views): the map has that view, and the back end keeps the tracker's local
//    map on the mapped keyframes the camera passes (weak inliers still make one). Revisiting a
//    mapped place adds keyframes mainly where the map lacks a verified view, so a map visited
//    every day grows far less (not zero: see docs/architecture.md).
// Front ends ask through KeyframeDecider (core/odometry/keyframe_decider.h).
#pragma once

#include <Eigen/Geometry>
#include <optional>

#include "common/status.h"
#include "core/odometry/keyframe_decider.h"

namespace semmap {

struct KeyframePolicyOptions {
  double min_motion = 0.10;      // threshold on the motion norm (metres-equivalent)
  double rotation_weight = 0.5;  // metres per radian: 0.1 rad of turning counts like 5 cm
  // Visual tracking: a keyframe when the inliers fall below this fraction of the inliers of
  // the first frame tracked against the reference; 0 disables the test.
  double min_inlier_fraction = 0.4;
  // Visual tracking: motion makes no keyframe when the frame is within min_motion of a
  // keyframe the map holds (KeyframeCandidate::mapped_keyframes) other than the reference.
  // The back end's half is SlamBackendOptions::follow_revisits (IngestOptions::Validate wants
  // both the same; semmapd sets both).
  bool skip_mapped_views = true;
  Status Validate() const;
};

class KeyframePolicy final : public KeyframeDecider {
 public:
  explicit KeyframePolicy(KeyframePolicyOptions options) : options_(options) {}

  bool Decide(const KeyframeCandidate& candidate) override;
  void ApplyCorrection(const Eigen::Isometry3d& T_corrected_world) override;

  // sqrt(|t|^2 + (w * angle)^2) of T_last_current.
  double MotionNorm(const Eigen::Isometry3d& T_last_current) const;
  const std::optional<Eigen::Isometry3d>& last_keyframe_pose() const { return T_world_last_; }
  const KeyframePolicyOptions& options() const { return options_; }

 private:
  bool MovedFarEnough(const Eigen::Isometry3d& T_world_camera) const;
  // A keyframe of the map's (candidate.mapped_keyframes) within min_motion of the frame, other
  // than the reference (keyframes within half of min_motion of it).
  bool MapHoldsTheView(const KeyframeCandidate& candidate) const;
  void StartFrom(const Eigen::Isometry3d& T_world_keyframe);

  KeyframePolicyOptions options_;
  std::optional<Eigen::Isometry3d> T_world_last_;  // the last keyframe
  // Inliers of the first frame tracked against the last keyframe; unset until one was.
  std::optional<int> reference_inliers_;
};

}  // namespace semmap
