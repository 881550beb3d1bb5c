#include "server/odometry/rgbd_refiner.h"

#include <Eigen/Cholesky>
#include <cmath>

namespace semmap {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

Eigen::Isometry3d Exp(const Vector6d& delta) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d w = delta.tail<3>();
  const double angle = w.norm();
  if (angle > 1e-12) T.linear() = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  T.translation() = delta.head<3>();
  return T;
}

// Whitened residual (2 or 3 rows) and its Jacobian under exp(delta) * T; false when the
// point is not in front of the camera.
bool Whitened(const RgbdObservation& o, const CameraCalibration& c, const Eigen::Isometry3d& T,
              double inverse_depth_sigma, bool use_depth, Eigen::Vector3d* r,
              Eigen::Matrix<double, 3, 6>* J, int* rows) {
  const Eigen::Vector3d p = T * o.point;
  if (!(p.z() > 1e-6)) return false;
  const double iz = 1.0 / p.z(), iz2 = iz * iz;
  const double wp = 1.0 / o.pixel_sigma;
  Eigen::Matrix<double, 3, 3> Jp;
  Jp << c.fx * iz, 0, -c.fx * p.x() * iz2, 0, c.fy * iz, -c.fy * p.y() * iz2, 0, 0, -iz2;
  Jp.topRows<2>() *= wp;
  (*r)(0) = wp * (c.fx * p.x() * iz + c.cx - o.pixel.x());
  (*r)(1) = wp * (c.fy * p.y() * iz + c.cy - o.pixel.y());
  *rows = 2;
  if (use_depth && o.inverse_depth > 0) {
    const double wd = 1.0 / inverse_depth_sigma;
    (*r)(2) = wd * (iz - o.inverse_depth);
    Jp.row(2) *= wd;
    *rows = 3;
  } else {
    (*r)(2) = 0;
    Jp.row(2).setZero();
  }
  Eigen::Matrix<double, 3, 6> Jd;
  Jd.leftCols<3>().setIdentity();
  Jd.rightCols<3>() << 0, p.z(), -p.y(), -p.z(), 0, p.x(), p.y(), -p.x(), 0;  // -[p]x
  *J = Jp * Jd;
  return true;
}

// Huber-weighted normal equations over the observations marked active; returns the cost.
double Linearise(const std::vector<RgbdObservation>& obs, const std::vector<bool>& active,
                 const CameraCalibration& c, const RgbdRefinerOptions& o,
                 const Eigen::Isometry3d& T, Matrix6d* H, Vector6d* g) {
  H->setZero();
  g->setZero();
  double cost = 0;
  Eigen::Vector3d r;
  Eigen::Matrix<double, 3, 6> J;
  int rows;
  for (size_t i = 0; i < obs.size(); ++i) {
    if (!active[i]) continue;
    if (!Whitened(obs[i], c, T, o.inverse_depth_sigma, o.use_depth, &r, &J, &rows)) continue;
    const double k = std::sqrt(rows == 3 ? o.chi2_3dof : o.chi2_2dof);
    const double n = r.norm();
    const double w = n <= k ? 1.0 : k / n;
    cost += n <= k ? 0.5 * n * n : k * (n - 0.5 * k);
    H->noalias() += w * J.transpose() * J;
    g->noalias() += w * J.transpose() * r;
  }
  return cost;
}

}  // namespace

Status RgbdRefinerOptions::Validate() const {
  if (!std::isfinite(inverse_depth_sigma) || inverse_depth_sigma <= 0) {
    return InvalidArgumentError("refiner inverse_depth_sigma must be positive");
  }
  if (rounds < 1 || rounds > 10 || iterations < 0 || iterations > 100) {
    return InvalidArgumentError("refiner rounds must be in [1, 10], iterations in [0, 100]");
  }
  if (!(chi2_2dof > 0) || !(chi2_3dof > 0)) {
    return InvalidArgumentError("refiner chi-square gates must be positive");
  }
  return OkStatus();
}

RgbdRefinement RefinePoseRgbd(const std::vector<RgbdObservation>& obs, const CameraCalibration& c,
                              const RgbdRefinerOptions& o, const Eigen::Isometry3d& T_start) {
  RgbdRefinement out;
  Eigen::Isometry3d T = T_start;
  std::vector<bool> active(obs.size(), true);
  Matrix6d H;
  Vector6d g;
  for (int round = 0; round < o.rounds; ++round) {
    double cost = Linearise(obs, active, c, o, T, &H, &g);
    double lambda = 1e-4;
    for (int it = 0; it < o.iterations; ++it) {
      Matrix6d A = H;
      A.diagonal() *= 1.0 + lambda;
      const Vector6d delta = A.ldlt().solve(-g);
      if (!delta.allFinite()) break;
      const Eigen::Isometry3d T_new = Exp(delta) * T;
      Matrix6d H_new;
      Vector6d g_new;
      const double cost_new = Linearise(obs, active, c, o, T_new, &H_new, &g_new);
      if (cost_new <= cost && T_new.matrix().allFinite()) {
        T = T_new;
        H = H_new;
        g = g_new;
        const bool converged = delta.norm() < 1e-9 || cost - cost_new < 1e-10 * (cost + 1e-12);
        cost = cost_new;
        lambda = std::max(1e-8, lambda * 0.1);
        if (converged) break;
      } else {
        lambda *= 10;
        if (lambda > 1e4) break;
      }
    }
    T.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
    // Reclassify every observation (outliers may come back) at the refined pose.
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 6> J;
    int rows;
    for (size_t i = 0; i < obs.size(); ++i) {
      active[i] = Whitened(obs[i], c, T, o.inverse_depth_sigma, o.use_depth, &r, &J, &rows) &&
                  r.squaredNorm() <= (rows == 3 ? o.chi2_3dof : o.chi2_2dof);
    }
  }
  out.T_current_reference = T;
  out.inlier = active;
  for (bool a : active) out.num_inliers += a ? 1 : 0;
  Linearise(obs, active, c, o, T, &out.information, &g);
  return out;
}

}  // namespace semmap
