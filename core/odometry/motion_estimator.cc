#include "core/odometry/motion_estimator.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <string>

#include "core/odometry/internal/pose_lm.h"

namespace semmap {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

bool IsFinite(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

// Reprojection residual of one correspondence; false when the point is not in front.
bool Residual(const CameraCalibration& c, const Eigen::Isometry3d& T_cr, const Eigen::Vector3d& X,
              const cv::Point2f& u, Eigen::Vector3d* p, Eigen::Vector2d* r) {
  *p = T_cr * X;
  if (!((*p).z() > 1e-6)) return false;
  (*r) << c.fx * p->x() / p->z() + c.cx - u.x, c.fy * p->y() / p->z() + c.cy - u.y;
  return true;
}

double HuberWeight(double norm, double k) { return norm <= k ? 1.0 : k / norm; }

double HuberCost(double norm, double k) {
  return norm <= k ? 0.5 * norm * norm : k * (norm - 0.5 * k);
}

// Normal equations of the Huber-weighted reprojection error under the left perturbation
// T_cr <- exp(delta) T_cr, delta = (translation, rotation). Returns the robust cost.
double Linearise(const std::vector<Eigen::Vector3d>& X, const std::vector<cv::Point2f>& u,
                 const CameraCalibration& c, double k, const Eigen::Isometry3d& T_cr, Matrix6d* H,
                 Vector6d* g) {
  H->setZero();
  g->setZero();
  double cost = 0;
  Eigen::Vector3d p;
  Eigen::Vector2d r;
  for (size_t i = 0; i < X.size(); ++i) {
    if (!Residual(c, T_cr, X[i], u[i], &p, &r)) continue;
    const double n = r.norm();
    const double w = HuberWeight(n, k);
    cost += HuberCost(n, k);
    const double iz = 1.0 / p.z(), iz2 = iz * iz;
    Eigen::Matrix<double, 2, 3> Jp;
    Jp << c.fx * iz, 0, -c.fx * p.x() * iz2, 0, c.fy * iz, -c.fy * p.y() * iz2;
    Eigen::Matrix<double, 3, 6> Jd;
    Jd.leftCols<3>().setIdentity();
    Jd.rightCols<3>() << 0, p.z(), -p.y(), -p.z(), 0, p.x(), p.y(), -p.x(), 0;  // -[p]x
    const Eigen::Matrix<double, 2, 6> J = Jp * Jd;
    H->noalias() += w * J.transpose() * J;
    g->noalias() += w * J.transpose() * r;
  }
  return cost;
}

std::vector<int> Inliers(const std::vector<Eigen::Vector3d>& X, const std::vector<cv::Point2f>& u,
                         const CameraCalibration& c, const Eigen::Isometry3d& T_cr,
                         double threshold, double* sum_sq) {
  std::vector<int> inliers;
  double s = 0;
  Eigen::Vector3d p;
  Eigen::Vector2d r;
  for (size_t i = 0; i < X.size(); ++i) {
    if (!Residual(c, T_cr, X[i], u[i], &p, &r)) continue;
    if (r.squaredNorm() <= threshold * threshold) {
      inliers.push_back(static_cast<int>(i));
      s += r.squaredNorm();
    }
  }
  if (sum_sq) *sum_sq = s;
  return inliers;
}

template <typename T>
std::vector<T> Subset(const std::vector<T>& v, const std::vector<int>& idx) {
  std::vector<T> out;
  out.reserve(idx.size());
  for (int i : idx) out.push_back(v[static_cast<size_t>(i)]);
  return out;
}

}  // namespace

Status MotionEstimatorOptions::Validate() const {
  if (min_matches < 4) return InvalidArgumentError("motion min_matches must be >= 4");
  if (min_inliers < 4) return InvalidArgumentError("motion min_inliers must be >= 4");
  if (!std::isfinite(ransac_threshold_px) || ransac_threshold_px <= 0) {
    return InvalidArgumentError("motion ransac_threshold_px must be positive");
  }
  if (ransac_iterations < 1) return InvalidArgumentError("motion ransac_iterations must be >= 1");
  if (!(ransac_confidence > 0 && ransac_confidence < 1)) {
    return InvalidArgumentError("motion ransac_confidence must be in (0, 1)");
  }
  if (!std::isfinite(huber_px) || huber_px <= 0) {
    return InvalidArgumentError("motion huber_px must be positive");
  }
  if (refine_iterations < 0 || refine_iterations > 100) {
    return InvalidArgumentError("motion refine_iterations must be in [0, 100]");
  }
  if (!std::isfinite(pixel_sigma) || pixel_sigma <= 0) {
    return InvalidArgumentError("motion pixel_sigma must be positive");
  }
  return OkStatus();
}

Eigen::Isometry3d RefinePose(const std::vector<Eigen::Vector3d>& X,
                             const std::vector<cv::Point2f>& u, const CameraCalibration& c,
                             const MotionEstimatorOptions& options,
                             const Eigen::Isometry3d& T_current_reference,
                             Eigen::Matrix<double, 6, 6>* information) {
  Eigen::Isometry3d T = T_current_reference;
  Matrix6d H;
  Vector6d g;
  RefineSe3(&T, options.refine_iterations, &H, &g,
            [&](const Eigen::Isometry3d& T_at, Matrix6d* H_at, Vector6d* g_at) {
              return Linearise(X, u, c, options.huber_px, T_at, H_at, g_at);
            });
  if (information) *information = H / (options.pixel_sigma * options.pixel_sigma);
  return T;
}

StatusOr<MotionEstimate> EstimateMotion(const std::vector<Eigen::Vector3d>& points_reference,
                                        const std::vector<cv::Point2f>& pixels_current,
                                        const CameraCalibration& camera,
                                        const MotionEstimatorOptions& options,
                                        const std::optional<Eigen::Isometry3d>& guess) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  if (points_reference.size() != pixels_current.size()) {
    return InvalidArgumentError("motion estimation: " + std::to_string(points_reference.size()) +
                                " points but " + std::to_string(pixels_current.size()) + " pixels");
  }
  const int n = static_cast<int>(points_reference.size());
  if (n < options.min_matches) {
    return FailedPreconditionError("too few matches (" + std::to_string(n) + " < " +
                                   std::to_string(options.min_matches) + ")");
  }
  std::vector<cv::Point3f> object(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d& X = points_reference[static_cast<size_t>(i)];
    const cv::Point2f& u = pixels_current[static_cast<size_t>(i)];
    if (!X.allFinite() || !std::isfinite(u.x) || !std::isfinite(u.y)) {
      return InvalidArgumentError("motion estimation: non-finite point or pixel " +
                                  std::to_string(i));
    }
    object[static_cast<size_t>(i)] = cv::Point3f(
        static_cast<float>(X.x()), static_cast<float>(X.y()), static_cast<float>(X.z()));
  }

  // Candidate starting poses T_current_reference: the RANSAC solution and the guess.
  std::vector<Eigen::Isometry3d> candidates;
  try {
    const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    cv::Mat rvec, tvec;
    std::vector<int> ransac_inliers;
    const int flags = options.method == PnpMethod::kSqpnp ? cv::SOLVEPNP_SQPNP : cv::SOLVEPNP_EPNP;
    const bool found = cv::solvePnPRansac(object, pixels_current, K, cv::noArray(), rvec, tvec,
                                          /*useExtrinsicGuess=*/false, options.ransac_iterations,
                                          static_cast<float>(options.ransac_threshold_px),
                                          options.ransac_confidence, ransac_inliers, flags);
    if (found && rvec.total() == 3 && tvec.total() == 3) {
      cv::Mat R;
      cv::Rodrigues(rvec, R);
      Eigen::Matrix3d Re;
      Eigen::Vector3d te;
      cv::cv2eigen(R, Re);
      cv::cv2eigen(tvec.reshape(1, 3), te);
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = Re;
      T.translation() = te;
      if (IsFinite(T)) candidates.push_back(T);
    }
  } catch (const cv::Exception& e) {
    return InternalError(std::string("PnP RANSAC: ") + e.what());
  }
  if (guess && IsFinite(*guess)) candidates.push_back(guess->inverse());
  if (candidates.empty()) {
    return FailedPreconditionError("PnP RANSAC found no pose from " + std::to_string(n) +
                                   " matches");
  }

  // Keep the candidate with most inliers, then alternate refinement and inlier selection.
  std::vector<int> best_inliers;
  Eigen::Isometry3d T_cr = candidates.front();
  for (const Eigen::Isometry3d& T : candidates) {
    std::vector<int> in =
        Inliers(points_reference, pixels_current, camera, T, options.ransac_threshold_px, nullptr);
    if (in.size() > best_inliers.size()) {
      best_inliers = std::move(in);
      T_cr = T;
    }
  }
  Matrix6d information = Matrix6d::Zero();
  for (int round = 0; round < 2 && best_inliers.size() >= 6; ++round) {
    const std::vector<Eigen::Vector3d> X = Subset(points_reference, best_inliers);
    const std::vector<cv::Point2f> u = Subset(pixels_current, best_inliers);
    T_cr = RefinePose(X, u, camera, options, T_cr, nullptr);
    best_inliers = Inliers(points_reference, pixels_current, camera, T_cr,
                           options.ransac_threshold_px, nullptr);
  }
  if (static_cast<int>(best_inliers.size()) < options.min_inliers) {
    return FailedPreconditionError("too few inliers (" + std::to_string(best_inliers.size()) +
                                   " < " + std::to_string(options.min_inliers) + ") among " +
                                   std::to_string(n) + " matches");
  }
  // Information at the final pose over the final inliers (no further steps).
  double sum_sq = 0;
  best_inliers =
      Inliers(points_reference, pixels_current, camera, T_cr, options.ransac_threshold_px, &sum_sq);
  {
    MotionEstimatorOptions no_steps = options;
    no_steps.refine_iterations = 0;
    RefinePose(Subset(points_reference, best_inliers), Subset(pixels_current, best_inliers), camera,
               no_steps, T_cr, &information);
  }
  if (!IsFinite(T_cr) || !information.allFinite()) {
    return InternalError("motion estimation produced a non-finite pose");
  }
  MotionEstimate out;
  out.T_reference_current = T_cr.inverse();
  out.inliers = std::move(best_inliers);
  out.information = information;
  Eigen::FullPivLU<Matrix6d> lu(information);
  if (lu.isInvertible()) out.covariance = lu.inverse();
  out.rms_reprojection_px =
      out.inliers.empty() ? 0.0 : std::sqrt(sum_sq / static_cast<double>(out.inliers.size()));
  return out;
}

}  // namespace semmap
