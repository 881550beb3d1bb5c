// Position and extent of a detected object from its inlier features' 3D points (keyframe
// frame) and the ray through the centre of its photo as the homography maps it into the
// keyframe. Separate from the detector so the geometry can be tested on exact points. See
// object_detector.h for why the plane centre rather than the median.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string_view>
#include <vector>

#include "core/recognition/object_model.h"

namespace semmap {

// How a position was found, best first (object_detector.h).
enum class PositionSource {
  kPlane,   // the centre ray meets the plane of the inlier points
  kRay,     // on the centre ray at the points' median distance along it (no plane fits)
  kMedian,  // the per-axis median of the points (no centre ray)
};

// "plane", "ray", "median".
std::string_view PositionSourceName(PositionSource source);

struct ObjectPosition {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector3d extent = Eigen::Vector3d::Zero();
  PositionSource source = PositionSource::kMedian;
};

// `points`: at least one. `centre_ray`: direction of the ray from the camera centre through the
// photo's projected centre (any length), or nullopt for the median. Uses options' plane
// settings, min_inliers_with_depth and the extent percentiles. Deterministic.
ObjectPosition EstimateObjectPosition(const std::vector<Eigen::Vector3d>& points,
                                      const std::optional<Eigen::Vector3d>& centre_ray,
                                      const ObjectRecognitionOptions& options);

// Linear-interpolated percentile (0..100) of `values` (not empty), which it sorts.
double Percentile(std::vector<double>& values, double percent);

}  // namespace semmap
