#include "core/slam/internal/relative_pose_error.h"

#include <Eigen/Eigenvalues>

namespace semmap::slam_internal {

Matrix6d SqrtInformation(const Matrix6d& information) {
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(0.5 * (information + information.transpose()));
  const Vector6d d = eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return d.asDiagonal() * eigen.eigenvectors().transpose();
}

Status ValidateInformation(const Matrix6d& information) {
  if (!information.allFinite()) return InvalidArgumentError("information is not finite");
  const double scale = information.cwiseAbs().maxCoeff();
  if ((information - information.transpose()).cwiseAbs().maxCoeff() > 1e-9 * scale) {
    return InvalidArgumentError("information is not symmetric");
  }
  Eigen::SelfAdjointEigenSolver<Matrix6d> eigen(information, Eigen::EigenvaluesOnly);
  if (eigen.eigenvalues().minCoeff() < -1e-9 * scale) {
    return InvalidArgumentError("information is not positive semi-definite");
  }
  return OkStatus();
}

}  // namespace semmap::slam_internal
