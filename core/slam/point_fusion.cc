#include "core/slam/point_fusion.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <unordered_map>
#include <unordered_set>

namespace semmap {
namespace {

constexpr double kCellPx = 16.0;

// The keyframe's keypoints bucketed by kCellPx cells, for radius searches.
class KeypointGrid {
 public:
  KeypointGrid(const FrameFeatures& features, int width, int height)
      : columns_(std::max(1, static_cast<int>(std::ceil(width / kCellPx)))),
        rows_(std::max(1, static_cast<int>(std::ceil(height / kCellPx)))),
        cells_(static_cast<size_t>(columns_ * rows_)) {
    for (size_t k = 0; k < features.size(); ++k) {
      const cv::Point2f& p = features.keypoints[k].pt;
      cells_[static_cast<size_t>(Cell(Row(p.y), Column(p.x)))].push_back(static_cast<int>(k));
    }
  }

  // Calls visit(keypoint) for every keypoint in the cells the square around (u, v) touches.
  template <typename Visit>
  void ForEachNear(double u, double v, double radius, Visit visit) const {
    for (int r = Row(v - radius); r <= Row(v + radius); ++r) {
      for (int c = Column(u - radius); c <= Column(u + radius); ++c) {
        for (int k : cells_[static_cast<size_t>(Cell(r, c))]) visit(k);
      }
    }
  }

 private:
  int Column(double x) const {
    return std::clamp(static_cast<int>(std::floor(x / kCellPx)), 0, columns_ - 1);
  }
  int Row(double y) const {
    return std::clamp(static_cast<int>(std::floor(y / kCellPx)), 0, rows_ - 1);
  }
  int Cell(int row, int column) const { return row * columns_ + column; }

  int columns_, rows_;
  std::vector<std::vector<int>> cells_;
};

}  // namespace

Status PointFusionOptions::Validate() const {
  if (!std::isfinite(search_radius_px) || search_radius_px <= 0) {
    return InvalidArgumentError("point fusion search_radius_px must be > 0");
  }
  if (!std::isfinite(octave_scale) || octave_scale < 1) {
    return InvalidArgumentError("point fusion octave_scale must be >= 1");
  }
  if (max_descriptor_distance < 0) {
    return InvalidArgumentError("point fusion max_descriptor_distance must be >= 0");
  }
  if (!std::isfinite(max_reprojection_chi2) || max_reprojection_chi2 <= 0) {
    return InvalidArgumentError("point fusion max_reprojection_chi2 must be > 0");
  }
  if (!std::isfinite(max_chi2_with_depth) || max_chi2_with_depth <= 0) {
    return InvalidArgumentError("point fusion max_chi2_with_depth must be > 0");
  }
  if (!std::isfinite(inverse_depth_sigma) || inverse_depth_sigma <= 0) {
    return InvalidArgumentError("point fusion inverse_depth_sigma must be > 0");
  }
  return OkStatus();
}

PointFusionResult FusePointsIntoKeyframe(int keyframe, const std::vector<int>& neighbours,
                                         const KeyframeGraph& graph, MapPoints& points,
                                         const PointFusionOptions& options) {
  PointFusionResult result;
  if (!options.enabled || keyframe < 0 || keyframe >= graph.size()) return result;
  const GraphKeyframe& target = graph.node(keyframe);
  if (target.culled || !target.features || target.camera == nullptr) return result;
  const FrameFeatures& features = *target.features;
  if (!features.binary_descriptors() || features.size() == 0) return result;
  const CameraCalibration& camera = *target.camera;

  std::unordered_map<int, int64_t> point_of_keypoint = points.PointsByKeypoint(keyframe);
  const std::vector<int64_t>& own = points.PointsOf(keyframe);
  const std::unordered_set<int64_t> observed(own.begin(), own.end());
  std::vector<int64_t> candidates;
  for (int n : neighbours) {
    if (n == keyframe || n < 0 || n >= graph.size() || graph.node(n).culled) continue;
    for (int64_t id : points.PointsOf(n)) {
      if (observed.count(id) == 0) candidates.push_back(id);
    }
  }
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());

  const KeypointGrid grid(features, camera.width, camera.height);
  const Eigen::Isometry3d T_keyframe_world = target.T_world_keyframe.inverse();
  for (int64_t id : candidates) {
    const MapPointState* point = points.Find(id);  // null once fused away in this pass
    if (point == nullptr || point->observations.empty()) continue;
    const Eigen::Vector3d p = T_keyframe_world * point->position_world;
    if (p.z() <= 0.05) continue;
    const double u = camera.fx * p.x() / p.z() + camera.cx;
    const double v = camera.fy * p.y() / p.z() + camera.cy;
    if (u < 0 || v < 0 || u >= camera.width || v >= camera.height) continue;
    // The point's descriptor and scale: those of its newest observation.
    const MapPointObservation& newest = point->observations.back();
    const GraphKeyframe& source = graph.node(newest.keyframe);
    if (source.culled || !source.features || !source.features->binary_descriptors()) continue;
    const cv::Mat descriptor = source.features->descriptors.row(newest.keypoint);
    const int octave = source.features->keypoints[static_cast<size_t>(newest.keypoint)].octave;
    const double radius = options.search_radius_px * std::pow(options.octave_scale, octave);

    int best = -1;
    double best_distance = std::numeric_limits<double>::max();
    grid.ForEachNear(u, v, radius, [&](int k) {
      const cv::KeyPoint& kp = features.keypoints[static_cast<size_t>(k)];
      if (std::abs(kp.octave - octave) > 1) return;
      const double sigma = std::pow(options.octave_scale, kp.octave);
      const double du = kp.pt.x - u, dv = kp.pt.y - v;
      if (du * du + dv * dv > radius * radius) return;
      const double pixel_chi2 = (du * du + dv * dv) / (sigma * sigma);
      if (features.has_depth[static_cast<size_t>(k)] &&
          features.points_camera[static_cast<size_t>(k)].z() > 0) {
        const double dinv = (1 / features.points_camera[static_cast<size_t>(k)].z() - 1 / p.z()) /
                            options.inverse_depth_sigma;
        if (pixel_chi2 + dinv * dinv > options.max_chi2_with_depth) return;
      } else if (pixel_chi2 > options.max_reprojection_chi2) {
        return;
      }
      const double distance = cv::norm(descriptor, features.descriptors.row(k), cv::NORM_HAMMING);
      if (distance < best_distance) {
        best_distance = distance;
        best = k;
      }
    });
    if (best < 0 || best_distance > options.max_descriptor_distance) continue;

    const auto there = point_of_keypoint.find(best);
    if (there == point_of_keypoint.end()) {
      if (points.AddObservation(id, ObservationOf(keyframe, best, features))) {
        point_of_keypoint[best] = id;
        ++result.observations_added;
      }
      continue;
    }
    const MapPointState* other = points.Find(there->second);
    if (other == nullptr || other->id == id) continue;
    // Two established points both stay unless asked (PointFusionOptions::merge_established).
    if (!options.merge_established && point->observations.size() > 1 &&
        other->observations.size() > 1) {
      continue;
    }
    // The better-established point stays (ties: the older).
    const bool keep_other =
        other->observations.size() > point->observations.size() ||
        (other->observations.size() == point->observations.size() && other->id < id);
    const int64_t keep = keep_other ? other->id : id;
    const int64_t drop = keep_other ? id : other->id;
    if (points.Fuse(keep, drop)) {
      there->second = keep;
      ++result.points_fused;
    }
  }
  return result;
}

}  // namespace semmap
