#include "client/eval/alignment.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <string>

namespace semmap {
namespace {

// Relative size below which a singular value counts as zero. Exactly degenerate input (a
// straight line, a point) leaves round-off of ~1e-16 relative; real trajectories are far above.
constexpr double kRankTolerance = 1e-10;

struct Centred {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  double sum_squares = 0;  // sum |p - mean|^2
  double max_abs = 0;      // largest coordinate magnitude (for "does not move")
  bool collinear = false;  // all points on one line (or one point)
};

Centred Describe(const std::vector<Eigen::Vector3d>& points) {
  Centred c;
  for (const Eigen::Vector3d& p : points) {
    c.mean += p;
    c.max_abs = std::max(c.max_abs, p.cwiseAbs().maxCoeff());
  }
  c.mean /= static_cast<double>(points.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d d = p - c.mean;
    covariance += d * d.transpose();
  }
  c.sum_squares = covariance.trace();
  const Eigen::Vector3d s = Eigen::JacobiSVD<Eigen::Matrix3d>(covariance).singularValues();
  c.collinear = s(1) <= kRankTolerance * s(0);
  return c;
}

bool DoesNotMove(const Centred& c, size_t n) {
  // RMS distance from the mean below round-off of the coordinates themselves.
  const double rms = std::sqrt(c.sum_squares / static_cast<double>(n));
  return !(rms > 1e-12 * std::max(1.0, c.max_abs));
}

}  // namespace

Eigen::Isometry3d Alignment::Apply(const Eigen::Isometry3d& T) const {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = rotation * T.linear();
  out.translation() = Apply(Eigen::Vector3d(T.translation()));
  return out;
}

StatusOr<Alignment> AlignPoints(const std::vector<Eigen::Vector3d>& source,
                                const std::vector<Eigen::Vector3d>& target, bool with_scale) {
  if (source.size() != target.size()) {
    return InvalidArgumentError(
        "alignment needs associated points: " + std::to_string(source.size()) + " vs " +
        std::to_string(target.size()));
  }
  const size_t n = source.size();
  if (n < 3) {
    return InvalidArgumentError("alignment needs at least 3 associated positions, got " +
                                std::to_string(n));
  }
  for (size_t i = 0; i < n; ++i) {
    if (!source[i].allFinite() || !target[i].allFinite()) {
      return InvalidArgumentError("alignment input has a non-finite position");
    }
  }
  const Centred s = Describe(source);
  const Centred t = Describe(target);
  if (DoesNotMove(s, n)) {
    return FailedPreconditionError(
        "the estimated positions do not move: no alignment (and no ATE) is defined");
  }
  if (DoesNotMove(t, n)) {
    return FailedPreconditionError(
        "the ground-truth positions do not move: no alignment (and no ATE) is defined");
  }
  // Cross-covariance sum_i (t_i - t_mean)(s_i - s_mean)^T: the transpose of evaluate_ate.py's W.
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    cross += (target[i] - t.mean) * (source[i] - s.mean).transpose();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d& sigma = svd.singularValues();
  if (!(sigma(0) > kRankTolerance * std::sqrt(s.sum_squares * t.sum_squares))) {
    return FailedPreconditionError(
        "the estimated and ground-truth motions are uncorrelated: the alignment rotation is "
        "undefined");
  }
  if (sigma(1) <= kRankTolerance * sigma(0) && !s.collinear && !t.collinear) {
    return FailedPreconditionError(
        "degenerate geometry: the alignment rotation about one axis is undefined (cross-covariance "
        "of rank 1)");
  }
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) S(2, 2) = -1;

  Alignment a;
  a.rotation = svd.matrixU() * S * svd.matrixV().transpose();
  if (with_scale) {
    double dots = 0;
    for (size_t i = 0; i < n; ++i) {
      dots += (target[i] - t.mean).dot(a.rotation * (source[i] - s.mean));
    }
    a.scale = dots / s.sum_squares;
    if (!(a.scale > 0) || !std::isfinite(a.scale)) {
      return FailedPreconditionError("degenerate geometry: the similarity scale is not positive (" +
                                     std::to_string(a.scale) + ")");
    }
  }
  a.translation = t.mean - a.scale * (a.rotation * s.mean);
  return a;
}

}  // namespace semmap
