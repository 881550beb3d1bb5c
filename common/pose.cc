#include "common/pose.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace semmap {

Status ValidatePoseTq(const PoseTq& pose) {
  if (!pose.t.allFinite() || !pose.q.coeffs().allFinite()) {
    return InvalidArgumentError("pose has a non-finite value");
  }
  if (pose.t.cwiseAbs().maxCoeff() > kMaxPositionM) {
    return InvalidArgumentError("pose position (" + std::to_string(pose.t.x()) + ", " +
                                std::to_string(pose.t.y()) + ", " + std::to_string(pose.t.z()) +
                                ") m is beyond 1e7 m on an axis: not a place on Earth");
  }
  const double norm = pose.q.norm();
  if (std::abs(norm - 1.0) > 1e-2) {
    return InvalidArgumentError("pose quaternion is not unit length (norm " + std::to_string(norm) +
                                ")");
  }
  return OkStatus();
}

Eigen::Isometry3d ToIsometry(const PoseTq& pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = pose.q.normalized().toRotationMatrix();
  T.translation() = pose.t;
  return T;
}

PoseTq ToPoseTq(const Eigen::Isometry3d& T) {
  PoseTq p;
  p.t = T.translation();
  p.q = Eigen::Quaterniond(T.linear()).normalized();  // linear(): no SVD, poses are rigid
  // Canonical sign (qw >= 0) keeps files and comparisons stable.
  if (p.q.w() < 0) p.q.coeffs() *= -1.0;
  return p;
}

double RotationAngle(const Eigen::Isometry3d& T) {
  const double c = (T.linear().trace() - 1.0) * 0.5;
  return std::acos(std::clamp(c, -1.0, 1.0));
}

Eigen::Isometry3d InterpolatePose(const Eigen::Isometry3d& T_a, const Eigen::Isometry3d& T_b,
                                  double alpha) {
  const Eigen::Quaterniond q_a(T_a.rotation());
  const Eigen::Quaterniond q_b(T_b.rotation());
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q_a.slerp(alpha, q_b).toRotationMatrix();
  T.translation() = (1.0 - alpha) * T_a.translation() + alpha * T_b.translation();
  return T;
}

}  // namespace semmap
