#include "core/recognition/object_position.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>

namespace semmap {
namespace {

struct Plane {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double spread = 0;  // sqrt of the middle eigenvalue: the thinner in-plane spread
};

Plane FitPlane(const std::vector<Eigen::Vector3d>& points) {
  Plane plane;
  for (const Eigen::Vector3d& p : points) plane.centroid += p;
  plane.centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d d = p - plane.centroid;
    cov += d * d.transpose();
  }
  cov /= static_cast<double>(points.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);  // ascending eigenvalues
  plane.normal = eig.eigenvectors().col(0);
  plane.spread = std::sqrt(std::max(0.0, eig.eigenvalues()[1]));
  return plane;
}

Eigen::Vector3d Extent(const std::vector<Eigen::Vector3d>& points,
                       const ObjectRecognitionOptions& options) {
  Eigen::Vector3d extent;
  std::vector<double> v(points.size());
  for (int a = 0; a < 3; ++a) {
    for (size_t i = 0; i < points.size(); ++i) v[i] = points[i][a];
    extent[a] = Percentile(v, options.extent_high_percentile) -
                Percentile(v, options.extent_low_percentile);
  }
  return extent;
}

// Deterministic RANSAC over point triples (a fixed SplitMix64 sequence: the same points give
// the same plane), then a least-squares refit on the best triple's inliers.
std::vector<Eigen::Vector3d> PlaneInliers(const std::vector<Eigen::Vector3d>& points,
                                          double tolerance, int iterations) {
  uint64_t state = 0x9E3779B97F4A7C15ULL;
  const auto next = [&state](size_t n) {
    state += 0x9E3779B97F4A7C15ULL;
    uint64_t z = state;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return static_cast<size_t>((z ^ (z >> 31)) % n);
  };
  const size_t n = points.size();
  size_t best_count = 0;
  Eigen::Vector3d best_normal = Eigen::Vector3d::Zero(), best_point = Eigen::Vector3d::Zero();
  for (int it = 0; it < iterations; ++it) {
    const size_t i = next(n), j = next(n), k = next(n);
    if (i == j || j == k || i == k) continue;
    const Eigen::Vector3d normal = (points[j] - points[i]).cross(points[k] - points[i]);
    if (normal.norm() < 1e-9) continue;
    const Eigen::Vector3d unit = normal.normalized();
    size_t count = 0;
    for (const Eigen::Vector3d& p : points) count += std::abs(unit.dot(p - points[i])) <= tolerance;
    if (count > best_count) {
      best_count = count;
      best_normal = unit;
      best_point = points[i];
    }
  }
  std::vector<Eigen::Vector3d> kept;
  if (best_count == 0) return kept;
  for (const Eigen::Vector3d& p : points) {
    if (std::abs(best_normal.dot(p - best_point)) <= tolerance) kept.push_back(p);
  }
  return kept;
}

// The plane centre, or nullopt when no plane fits well enough (see object_model.h).
std::optional<ObjectPosition> OnPlane(const std::vector<Eigen::Vector3d>& points,
                                      const Eigen::Vector3d& ray,
                                      const ObjectRecognitionOptions& options) {
  const size_t need = std::max<size_t>(3, static_cast<size_t>(options.min_inliers_with_depth));
  if (points.size() < need) return std::nullopt;
  std::vector<double> z(points.size());
  for (size_t i = 0; i < points.size(); ++i) z[i] = points[i].z();
  const double depth = Percentile(z, 50.0);
  const double tolerance =
      options.plane_tolerance_m + options.plane_tolerance_per_m2 * depth * depth;
  const std::vector<Eigen::Vector3d> kept = PlaneInliers(points, tolerance, 100);
  if (kept.size() < need || 2 * kept.size() < points.size()) return std::nullopt;
  const Plane plane = FitPlane(kept);
  if (plane.spread < options.plane_min_spread_m) return std::nullopt;
  const Eigen::Vector3d d = ray.normalized();
  const double cos_angle = plane.normal.dot(d);
  if (std::abs(cos_angle) < std::sin(10.0 * M_PI / 180.0)) return std::nullopt;  // grazing
  const double t = plane.normal.dot(plane.centroid) / cos_angle;
  if (!(t > 0) || !std::isfinite(t)) return std::nullopt;  // behind the camera
  ObjectPosition out;
  out.p = t * d;
  out.extent = Extent(kept, options);
  out.source = PositionSource::kPlane;
  return out;
}

}  // namespace

double Percentile(std::vector<double>& values, double percent) {
  std::sort(values.begin(), values.end());
  const double pos =
      std::clamp(percent, 0.0, 100.0) / 100.0 * static_cast<double>(values.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (pos - static_cast<double>(lo)) * (values[hi] - values[lo]);
}

ObjectPosition EstimateObjectPosition(const std::vector<Eigen::Vector3d>& points,
                                      const std::optional<Eigen::Vector3d>& centre_ray,
                                      const ObjectRecognitionOptions& options) {
  if (points.empty()) return {};
  const bool have_ray = centre_ray && centre_ray->allFinite() && centre_ray->norm() > 0;
  if (have_ray) {
    if (std::optional<ObjectPosition> p = OnPlane(points, *centre_ray, options)) return *p;
  }
  ObjectPosition out;
  out.extent = Extent(points, options);
  std::vector<double> v(points.size());
  if (have_ray) {
    // On the ray, at the median of the points' distances along it.
    const Eigen::Vector3d d = centre_ray->normalized();
    for (size_t i = 0; i < points.size(); ++i) v[i] = d.dot(points[i]);
    const double t = Percentile(v, 50.0);
    if (t > 0) {
      out.p = t * d;
      out.source = PositionSource::kRay;
      return out;
    }
  }
  for (int a = 0; a < 3; ++a) {
    for (size_t i = 0; i < points.size(); ++i) v[i] = points[i][a];
    out.p[a] = Percentile(v, 50.0);
  }
  out.source = PositionSource::kMedian;
  return out;
}

std::string_view PositionSourceName(PositionSource source) {
  switch (source) {
    case PositionSource::kPlane:
      return "plane";
    case PositionSource::kRay:
      return "ray";
    case PositionSource::kMedian:
      return "median";
  }
  return "unknown";
}

}  // namespace semmap
