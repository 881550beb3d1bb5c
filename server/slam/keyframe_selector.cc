#include "server/slam/keyframe_selector.h"

#include <cmath>
#include <string>

#include "common/pose.h"

namespace semmap {

Status KeyframeSelectorOptions::Validate() const {
  if (!std::isfinite(min_motion) || min_motion <= 0) {
    return InvalidArgumentError("keyframe min_motion must be positive (got " +
                                std::to_string(min_motion) + ")");
  }
  if (!std::isfinite(rotation_weight) || rotation_weight < 0) {
    return InvalidArgumentError("keyframe rotation_weight must be >= 0 (got " +
                                std::to_string(rotation_weight) + ")");
  }
  return OkStatus();
}

double KeyframeSelector::MotionNorm(const Eigen::Isometry3d& T_last_current) const {
  const double t = T_last_current.translation().norm();
  const double r = options_.rotation_weight * RotationAngle(T_last_current);
  return std::sqrt(t * t + r * r);
}

bool KeyframeSelector::Decide(const Eigen::Isometry3d& T_world_camera) {
  if (!T_world_last_ ||
      MotionNorm(T_world_last_->inverse() * T_world_camera) > options_.min_motion) {
    T_world_last_ = T_world_camera;
    return true;
  }
  return false;
}

}  // namespace semmap
