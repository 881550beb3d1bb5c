// Keyframe decision of the seed algorithm: a frame becomes a keyframe when the norm of its
// motion since the last keyframe exceeds a threshold.
#pragma once

#include <Eigen/Geometry>
#include <optional>

#include "common/status.h"

namespace semmap {

struct KeyframeSelectorOptions {
  double min_motion = 0.10;      // threshold on the motion norm below (metres-equivalent)
  double rotation_weight = 0.5;  // metres per radian: 0.1 rad of turning counts like 5 cm
  Status Validate() const;
};

class KeyframeSelector {
 public:
  explicit KeyframeSelector(KeyframeSelectorOptions options) : options_(options) {}

  // sqrt(|t|^2 + (w * angle)^2) of T_last_current.
  double MotionNorm(const Eigen::Isometry3d& T_last_current) const;

  // True for the first frame and whenever the motion norm exceeds min_motion; a true result
  // makes this frame the new reference.
  bool Decide(const Eigen::Isometry3d& T_world_camera);

  const std::optional<Eigen::Isometry3d>& last_keyframe_pose() const { return T_world_last_; }

 private:
  KeyframeSelectorOptions options_;
  std::optional<Eigen::Isometry3d> T_world_last_;
};

}  // namespace semmap
