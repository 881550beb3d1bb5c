// The cost of one bundle-adjustment observation with analytic Jacobians: over the parameter
// blocks (t_world_camera, q_world_camera in Eigen's x, y, z, w order, point_world), the
// whitened reprojection error (2) and, with depth, the whitened inverse-depth error (3rd).
// Residual evaluation was a quarter of a local BA's time with automatic differentiation.
// Private to core/slam; tests/unit/slam/observation_cost_test.cc checks it against autodiff.
#pragma once

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace semmap::slam_internal {

struct ObservationModel {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double u = 0, v = 0;             // the observed (undistorted) pixel
  double inverse_pixel_sigma = 1;  // 1 / pixel sigma
  double inverse_depth = 0;        // measured 1 / depth (with depth)
  double inverse_inverse_depth_sigma = 1;
};

template <int kResiduals>  // 2: reprojection only; 3: with the inverse-depth term
class ObservationCost final : public ceres::SizedCostFunction<kResiduals, 3, 4, 3> {
 public:
  explicit ObservationCost(const ObservationModel& model) : m_(model) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const Eigen::Map<const Eigen::Vector3d> t(parameters[0]), x(parameters[2]);
    const double qw = parameters[1][3];
    const Eigen::Map<const Eigen::Vector3d> qv(parameters[1]);
    // p = conj(q) * (x - t), written as Eigen rotates (a + 2w(u x a) + 2u x (u x a), u = -qv)
    // so that it is the same function of the four coefficients as the autodiff version.
    const Eigen::Vector3d a = x - t;
    const Eigen::Vector3d va = qv.cross(a);
    const Eigen::Vector3d p = a - 2 * qw * va + 2 * qv.cross(va);
    // A point behind the camera: infeasible (Ceres shrinks the step).
    if (p.z() <= 1e-6) return false;
    const double iz = 1 / p.z();
    residuals[0] = (m_.fx * p.x() * iz + m_.cx - m_.u) * m_.inverse_pixel_sigma;
    residuals[1] = (m_.fy * p.y() * iz + m_.cy - m_.v) * m_.inverse_pixel_sigma;
    if constexpr (kResiduals == 3) {
      residuals[2] = (iz - m_.inverse_depth) * m_.inverse_inverse_depth_sigma;
    }
    if (jacobians == nullptr) return true;

    Eigen::Matrix<double, kResiduals, 3> dr_dp = Eigen::Matrix<double, kResiduals, 3>::Zero();
    dr_dp(0, 0) = m_.fx * iz * m_.inverse_pixel_sigma;
    dr_dp(0, 2) = -m_.fx * p.x() * iz * iz * m_.inverse_pixel_sigma;
    dr_dp(1, 1) = m_.fy * iz * m_.inverse_pixel_sigma;
    dr_dp(1, 2) = -m_.fy * p.y() * iz * iz * m_.inverse_pixel_sigma;
    if constexpr (kResiduals == 3) dr_dp(2, 2) = -iz * iz * m_.inverse_inverse_depth_sigma;
    // dp/da = I - 2w [v]x + 2 [v]x [v]x.
    const Eigen::Matrix3d vx = Skew(qv);
    const Eigen::Matrix3d dp_da = Eigen::Matrix3d::Identity() - 2 * qw * vx + 2 * vx * vx;
    using Jacobian3 = Eigen::Matrix<double, kResiduals, 3, Eigen::RowMajor>;
    using Jacobian4 = Eigen::Matrix<double, kResiduals, 4, Eigen::RowMajor>;
    if (jacobians[0] != nullptr) {
      Eigen::Map<Jacobian3> dr_dt(jacobians[0]);
      dr_dt = -dr_dp * dp_da;
    }
    if (jacobians[1] != nullptr) {
      Eigen::Matrix<double, 3, 4> dp_dq;
      // d/dv: 2w [a]x + 2 ((v.a) I + v a^T - 2 a v^T); d/dw: -2 (v x a).
      dp_dq.leftCols<3>() = 2 * qw * Skew(a) + 2 * (qv.dot(a) * Eigen::Matrix3d::Identity() +
                                                    qv * a.transpose() - 2 * a * qv.transpose());
      dp_dq.col(3) = -2 * va;
      Eigen::Map<Jacobian4> dr_dq(jacobians[1]);
      dr_dq = dr_dp * dp_dq;
    }
    if (jacobians[2] != nullptr) {
      Eigen::Map<Jacobian3> dr_dx(jacobians[2]);
      dr_dx = dr_dp * dp_da;
    }
    return true;
  }

 private:
  static Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
    Eigen::Matrix3d s;
    s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return s;
  }

  ObservationModel m_;
};

}  // namespace semmap::slam_internal
