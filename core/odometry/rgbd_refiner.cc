#include "core/odometry/rgbd_refiner.h"

#include <Eigen/Cholesky>
#include <cmath>

#include "core/odometry/internal/pose_lm.h"

namespace semmap {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

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
    // H is symmetric: its upper triangle only (21 of 36 entries), mirrored once below; a
    // depth-less observation has a zero third row, left out.
    for (int a = 0; a < 6; ++a) {
      for (int b = a; b < 6; ++b) {
        double sum = J(0, a) * J(0, b) + J(1, a) * J(1, b);
        if (rows == 3) sum += J(2, a) * J(2, b);
        (*H)(a, b) += w * sum;
      }
    }
    g->noalias() += w * J.transpose() * r;
  }
  for (int a = 1; a < 6; ++a) {
    for (int b = 0; b < a; ++b) (*H)(a, b) = (*H)(b, a);
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
    RefineSe3(&T, o.iterations, &H, &g,
              [&](const Eigen::Isometry3d& T_at, Matrix6d* H_at, Vector6d* g_at) {
                return Linearise(obs, active, c, o, T_at, H_at, g_at);
              });
    // Reclassify every observation (outliers may come back) at the refined pose.
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 6> J;
    int rows;
    bool changed = false;
    for (size_t i = 0; i < obs.size(); ++i) {
      const bool inlier =
          Whitened(obs[i], c, T, o.inverse_depth_sigma, o.use_depth, &r, &J, &rows) &&
          r.squaredNorm() <= (rows == 3 ? o.chi2_3dof : o.chi2_2dof);
      changed = changed || inlier != active[i];
      active[i] = inlier;
    }
    // The same inliers as the round just solved: another round would solve the same problem.
    if (!changed) break;
  }
  out.T_current_reference = T;
  out.inlier = active;
  for (bool a : active) out.num_inliers += a ? 1 : 0;
  Linearise(obs, active, c, o, T, &out.information, &g);
  return out;
}

}  // namespace semmap
