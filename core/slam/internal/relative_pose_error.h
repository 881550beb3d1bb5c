// The residual of a relative-pose measurement between two poses, shared by the pose graph
// (odometry and loop edges) and bundle adjustment (loop edges kept while points are refined).
// Private to core/slam.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/status.h"

namespace semmap::slam_internal {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Residual over the parameter blocks (t_world_from, q_world_from, t_world_to, q_world_to);
// quaternions in Eigen's (x, y, z, w) order. r = L * (t_err, 2 * vec(q_err)) for
// T_err = T_from_to^-1 * T_world_from^-1 * T_world_to, L^T L = information.
class RelativePoseError {
 public:
  RelativePoseError(const Eigen::Isometry3d& T_from_to, const Matrix6d& sqrt_information)
      : t_to_from_(T_from_to.inverse().translation()),
        q_to_from_(Eigen::Quaterniond(T_from_to.linear()).normalized().conjugate()),
        sqrt_information_(sqrt_information) {}

  template <typename T>
  bool operator()(const T* t_wf_ptr, const T* q_wf_ptr, const T* t_wt_ptr, const T* q_wt_ptr,
                  T* residual_ptr) const {
    using Vec3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Vec3> t_wf(t_wf_ptr), t_wt(t_wt_ptr);
    const Eigen::Map<const Eigen::Quaternion<T>> q_wf(q_wf_ptr), q_wt(q_wt_ptr);
    // Estimated T_from_to, then T_err = measured^-1 * estimated.
    const Eigen::Quaternion<T> q_fw = q_wf.conjugate();
    const Eigen::Quaternion<T> q_ft = q_fw * q_wt;
    const Vec3 t_ft = q_fw * (t_wt - t_wf);
    const Eigen::Quaternion<T> q_tf_measured = q_to_from_.cast<T>();
    Eigen::Quaternion<T> q_err = q_tf_measured * q_ft;
    // q and -q are the same rotation; take the short way so 2 * vec grows with the angle.
    if (q_err.w() < T(0)) q_err.coeffs() = -q_err.coeffs();
    Eigen::Matrix<T, 6, 1> error;
    error.template head<3>() = q_tf_measured * t_ft + t_to_from_.cast<T>();
    error.template tail<3>() = T(2) * q_err.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> residual(residual_ptr);
    residual = sqrt_information_.cast<T>() * error;
    return true;
  }

 private:
  Eigen::Vector3d t_to_from_;
  Eigen::Quaterniond q_to_from_;
  Matrix6d sqrt_information_;
};

// L with L^T L = information, by eigen-decomposition so a PSD (rank-deficient) information
// works where LLT would fail; tiny negative round-off eigenvalues are clamped to zero.
Matrix6d SqrtInformation(const Matrix6d& information);

// INVALID_ARGUMENT unless finite, symmetric and positive semi-definite.
Status ValidateInformation(const Matrix6d& information);

}  // namespace semmap::slam_internal
