#include "core/slam/internal/ceres_support.h"

#include <ceres/ceres.h>

#include <Eigen/Core>

namespace semmap::slam_internal {

Status ValidateRigidPose(const Eigen::Isometry3d& T) {
  if (!T.matrix().allFinite()) return InvalidArgumentError("pose is not finite");
  const Eigen::Matrix3d R = T.linear();
  // Loose enough for rotations that went through float, tight enough to catch a scaled or
  // sheared matrix whose quaternion would silently be something else.
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-5 ||
      R.determinant() <= 0) {
    return InvalidArgumentError("pose rotation is not orthonormal");
  }
  return OkStatus();
}

ceres::SparseLinearAlgebraLibraryType ChooseSparseLibrary(bool* available) {
  for (auto type :
       {ceres::SUITE_SPARSE, ceres::EIGEN_SPARSE, ceres::ACCELERATE_SPARSE, ceres::CX_SPARSE}) {
    if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(type)) {
      *available = true;
      return type;
    }
  }
  *available = false;
  return ceres::NO_SPARSE;
}

Eigen::Isometry3d PoseFromParameters(const double* t, const double* q) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Map<const Eigen::Vector3d>(t);
  T.linear() = Eigen::Map<const Eigen::Quaterniond>(q).normalized().toRotationMatrix();
  return T;
}

}  // namespace semmap::slam_internal
