// Rigid-body pose helpers. Every pose in semmap is named T_<to>_<from>: T_world_camera maps
// points from the camera frame into the world frame.
#pragma once

#include <Eigen/Geometry>

#include "common/status.h"

namespace semmap {

// Translation + unit quaternion, the form poses take on the wire and in files.
struct PoseTq {
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
};

// Positions beyond this (10,000 km per axis) are not a place: it covers any UTM easting or
// northing and Earth-centred coordinates, with room to spare.
inline constexpr double kMaxPositionM = 1e7;

// Rejects non-finite values, positions beyond kMaxPositionM on an axis and quaternions whose
// norm is not within 1e-2 of one (a zero quaternion is a degenerate pose, not a rotation).
Status ValidatePoseTq(const PoseTq& pose);

// Builds an isometry; the quaternion is normalised (call ValidatePoseTq first).
Eigen::Isometry3d ToIsometry(const PoseTq& pose);
PoseTq ToPoseTq(const Eigen::Isometry3d& T);

// Angle of the rotation part in radians, in [0, pi].
double RotationAngle(const Eigen::Isometry3d& T);

// Interpolates translation linearly and rotation by slerp; alpha in [0, 1].
Eigen::Isometry3d InterpolatePose(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b,
                                  double alpha);

}  // namespace semmap
