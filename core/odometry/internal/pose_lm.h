// Levenberg-Marquardt on one SE(3) pose under a left perturbation exp(delta) * T, delta =
// (translation, rotation): the loop shared by the motion-only refinements. The caller's
// linearisation gives the cost, J^T W J and J^T W r at a pose.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>

namespace semmap {

using PoseMatrix6d = Eigen::Matrix<double, 6, 6>;
using PoseVector6d = Eigen::Matrix<double, 6, 1>;

inline Eigen::Isometry3d ExpSe3(const PoseVector6d& delta) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d w = delta.tail<3>();
  const double angle = w.norm();
  if (angle > 1e-12) T.linear() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  T.translation() = delta.head<3>();
  return T;
}

// Refines *T for at most `iterations` accepted or rejected steps; on return *H and *g are the
// normal equations at the final pose (H / sigma^2 is the information). `linearise(T, H, g)`
// returns the cost at T and fills H and g.
template <typename Linearise>
void RefineSe3(Eigen::Isometry3d* T, int iterations, PoseMatrix6d* H, PoseVector6d* g,
               const Linearise& linearise) {
  double cost = linearise(*T, H, g);
  double lambda = 1e-4;  // Levenberg damping, relative to the diagonal
  for (int it = 0; it < iterations; ++it) {
    PoseMatrix6d A = *H;
    A.diagonal() *= 1.0 + lambda;
    const PoseVector6d delta = A.ldlt().solve(-*g);
    if (!delta.allFinite()) break;
    const Eigen::Isometry3d T_new = ExpSe3(delta) * *T;
    PoseMatrix6d H_new;
    PoseVector6d g_new;
    const double cost_new = linearise(T_new, &H_new, &g_new);
    if (cost_new <= cost && T_new.matrix().allFinite()) {
      *T = T_new;
      *H = H_new;
      *g = g_new;
      const bool converged = delta.norm() < 1e-9 || cost - cost_new < 1e-10 * (cost + 1e-12);
      cost = cost_new;
      lambda = std::max(1e-8, lambda * 0.1);
      if (converged) break;
    } else {
      lambda *= 10;
      if (lambda > 1e4) break;
    }
  }
  T->linear() = Eigen::Quaterniond(T->linear()).normalized().toRotationMatrix();
}

}  // namespace semmap
