#include "client/eval/kitti_metric.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <string>

namespace semmap {
namespace {

// The devkit keeps distances, lengths and errors in `float`; the expressions below reproduce
// its arithmetic operation by operation (the poses themselves stay double, as there).

std::vector<float> TrajectoryDistances(const std::vector<StampedPose>& poses) {
  std::vector<float> dist{0.0f};
  for (size_t i = 1; i < poses.size(); ++i) {
    const Eigen::Vector3d a = poses[i - 1].T_world_camera.translation();
    const Eigen::Vector3d b = poses[i].T_world_camera.translation();
    const float dx = static_cast<float>(a.x() - b.x());
    const float dy = static_cast<float>(a.y() - b.y());
    const float dz = static_cast<float>(a.z() - b.z());
    dist.push_back(dist[i - 1] + std::sqrt(dx * dx + dy * dy + dz * dz));
  }
  return dist;
}

int LastFrameFromSegmentLength(const std::vector<float>& dist, size_t first_frame, float length) {
  for (size_t i = first_frame; i < dist.size(); ++i) {
    if (dist[i] > dist[first_frame] + length) return static_cast<int>(i);
  }
  return -1;
}

float RotationError(const Eigen::Isometry3d& error) {
  const float a = static_cast<float>(error.linear()(0, 0));
  const float b = static_cast<float>(error.linear()(1, 1));
  const float c = static_cast<float>(error.linear()(2, 2));
  const float d = static_cast<float>(0.5 * (a + b + c - 1.0));
  return std::acos(std::max(std::min(d, 1.0f), -1.0f));
}

float TranslationError(const Eigen::Isometry3d& error) {
  const float dx = static_cast<float>(error.translation().x());
  const float dy = static_cast<float>(error.translation().y());
  const float dz = static_cast<float>(error.translation().z());
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

std::string Metres(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.6g", v);
  return text;
}

double ToPercent(float t_err) { return 100.0 * static_cast<double>(t_err); }
double ToDegPer100m(float r_err) {
  return static_cast<double>(r_err) * (180.0 / std::numbers::pi) * 100.0;
}

}  // namespace

Status KittiOptions::Validate() const {
  if (lengths_m.empty()) return InvalidArgumentError("no segment lengths given");
  for (double length : lengths_m) {
    if (!std::isfinite(length) || !(length > 0) || length > 1e7) {
      return InvalidArgumentError("segment lengths must be positive metres, got " + Metres(length));
    }
  }
  for (size_t i = 0; i < lengths_m.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (static_cast<float>(lengths_m[i]) == static_cast<float>(lengths_m[j])) {
        return InvalidArgumentError("segment length " + Metres(lengths_m[i]) + " is given twice");
      }
    }
  }
  if (step_frames < 1) {
    return InvalidArgumentError("step must be at least one frame, got " +
                                std::to_string(step_frames));
  }
  return OkStatus();
}

StatusOr<KittiResult> ComputeKittiMetric(const std::vector<StampedPose>& ground_truth,
                                         const std::vector<StampedPose>& estimate,
                                         const KittiOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  if (ground_truth.empty()) return InvalidArgumentError("the ground truth has no poses");
  if (ground_truth.size() != estimate.size()) {
    return InvalidArgumentError(
        "the KITTI metric compares frame by frame, but the ground truth has " +
        std::to_string(ground_truth.size()) + " poses and the estimate " +
        std::to_string(estimate.size()));
  }
  if (ground_truth.size() > static_cast<size_t>(std::numeric_limits<int>::max())) {
    return InvalidArgumentError("too many poses");
  }
  for (size_t i = 0; i < ground_truth.size(); ++i) {
    if (!ground_truth[i].T_world_camera.matrix().allFinite() ||
        !estimate[i].T_world_camera.matrix().allFinite()) {
      return InvalidArgumentError("pose " + std::to_string(i) + " has a non-finite value");
    }
  }

  const std::vector<float> dist = TrajectoryDistances(ground_truth);
  std::vector<float> lengths;
  for (double length : options.lengths_m) lengths.push_back(static_cast<float>(length));

  KittiResult result;
  result.gt_path_length_m = dist.back();
  for (size_t first = 0; first < ground_truth.size(); first += options.step_frames) {
    for (float length : lengths) {
      const int last = LastFrameFromSegmentLength(dist, first, length);
      if (last < 0) continue;
      const Eigen::Isometry3d& gt_first = ground_truth[first].T_world_camera;
      const Eigen::Isometry3d& est_first = estimate[first].T_world_camera;
      const Eigen::Isometry3d delta_gt = gt_first.inverse() * ground_truth[last].T_world_camera;
      const Eigen::Isometry3d delta_est = est_first.inverse() * estimate[last].T_world_camera;
      const Eigen::Isometry3d error = delta_est.inverse() * delta_gt;
      KittiSegment segment;
      segment.first_frame = static_cast<int>(first);
      segment.last_frame = last;
      segment.length_m = length;
      segment.r_err = RotationError(error) / length;
      segment.t_err = TranslationError(error) / length;
      result.segments.push_back(segment);
    }
  }
  if (result.segments.empty()) {
    return FailedPreconditionError("the ground-truth path is " + Metres(result.gt_path_length_m) +
                                   " m long: no segment of " +
                                   Metres(*std::min_element(lengths.begin(), lengths.end())) +
                                   " m fits (use shorter segment lengths)");
  }

  float t_sum = 0;
  float r_sum = 0;
  for (const KittiSegment& s : result.segments) {
    t_sum += s.t_err;
    r_sum += s.r_err;
  }
  const float count = static_cast<float>(result.segments.size());
  result.t_err = t_sum / count;
  result.r_err = r_sum / count;
  result.t_rel_percent = ToPercent(result.t_err);
  result.r_rel_deg_per_100m = ToDegPer100m(result.r_err);

  for (float length : lengths) {
    KittiLengthStats stats;
    stats.length_m = length;
    float t = 0;
    float r = 0;
    float num = 0;
    for (const KittiSegment& s : result.segments) {
      if (s.length_m == length) {
        t += s.t_err;
        r += s.r_err;
        num += 1;
      }
    }
    if (num < 0.5f) continue;
    stats.segments = static_cast<size_t>(num);
    stats.t_err = t / num;
    stats.r_err = r / num;
    stats.t_rel_percent = ToPercent(stats.t_err);
    stats.r_rel_deg_per_100m = ToDegPer100m(stats.r_err);
    result.per_length.push_back(stats);
  }
  return result;
}

}  // namespace semmap
