#include "core/slam/keyframe_policy.h"

#include <cmath>
#include <string>

#include "common/pose.h"

namespace semmap {

Status KeyframePolicyOptions::Validate() const {
  if (!std::isfinite(min_motion) || min_motion <= 0) {
    return InvalidArgumentError("keyframe min_motion must be positive (got " +
                                std::to_string(min_motion) + ")");
  }
  if (!std::isfinite(rotation_weight) || rotation_weight < 0) {
    return InvalidArgumentError("keyframe rotation_weight must be >= 0 (got " +
                                std::to_string(rotation_weight) + ")");
  }
  if (!std::isfinite(min_inlier_fraction) || min_inlier_fraction < 0 || min_inlier_fraction >= 1) {
    return InvalidArgumentError("keyframe min_inlier_fraction must be in [0, 1) (got " +
                                std::to_string(min_inlier_fraction) + ")");
  }
  return OkStatus();
}

double KeyframePolicy::MotionNorm(const Eigen::Isometry3d& T_last_current) const {
  const double t = T_last_current.translation().norm();
  const double r = options_.rotation_weight * RotationAngle(T_last_current);
  return std::sqrt(t * t + r * r);
}

bool KeyframePolicy::MovedFarEnough(const Eigen::Isometry3d& T_world_camera) const {
  return !T_world_last_ ||
         MotionNorm(T_world_last_->inverse() * T_world_camera) > options_.min_motion;
}

bool KeyframePolicy::MapHoldsTheView(const KeyframeCandidate& candidate) const {
  if (!options_.skip_mapped_views || candidate.mapped_keyframes == nullptr) return false;
  const Eigen::Isometry3d T_camera_world = candidate.T_world_camera.inverse();
  for (const Eigen::Isometry3d& T_world_keyframe : *candidate.mapped_keyframes) {
    if (MotionNorm(T_camera_world * T_world_keyframe) > options_.min_motion) continue;
    // The reference keyframe itself (as the back end refined it) does not count: a frame
    // whose inliers fall while it is still near the reference sees what the map lacks.
    if (T_world_last_ &&
        MotionNorm(T_world_last_->inverse() * T_world_keyframe) <= 0.5 * options_.min_motion) {
      continue;
    }
    return true;
  }
  return false;
}

void KeyframePolicy::StartFrom(const Eigen::Isometry3d& T_world_keyframe) {
  T_world_last_ = T_world_keyframe;
  reference_inliers_.reset();
}

bool KeyframePolicy::Decide(const KeyframeCandidate& candidate) {
  bool keyframe = false;
  switch (candidate.evidence) {
    case KeyframeEvidence::kSegmentStart:
      keyframe = true;
      break;
    case KeyframeEvidence::kKnownPose:
    case KeyframeEvidence::kPredicted:
      keyframe = MovedFarEnough(candidate.T_world_camera);
      break;
    case KeyframeEvidence::kRelocalised:
      keyframe = candidate.has_depth;
      break;
    case KeyframeEvidence::kTracked: {
      if (!candidate.has_depth) break;
      if (!reference_inliers_) reference_inliers_ = candidate.num_inliers;
      const bool weak = candidate.num_inliers < options_.min_inlier_fraction * *reference_inliers_;
      // Weak tracking makes a keyframe even where the map holds the view: the tracker's local
      // map has run out there (a refresh not yet arrived, the scene changed), and waiting for
      // the back end could lose the frame.
      keyframe = weak || (MovedFarEnough(candidate.T_world_camera) && !MapHoldsTheView(candidate));
      break;
    }
  }
  if (keyframe) StartFrom(candidate.T_world_camera);
  return keyframe;
}

void KeyframePolicy::ApplyCorrection(const Eigen::Isometry3d& T_corrected_world) {
  if (T_world_last_) T_world_last_ = T_corrected_world * *T_world_last_;
}

}  // namespace semmap
