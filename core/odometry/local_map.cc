#include "core/odometry/local_map.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <unordered_map>
#include <unordered_set>

namespace semmap {
namespace {

// Keeps the points `keep` accepts, in order, with their descriptor rows; the descriptor matrix
// (`cols` x `type`) gets `extra_rows` more rows after them for points the caller appends.
// Returns the number kept.
template <typename Keep>
size_t KeepPoints(std::vector<MapPoint>* points, cv::Mat* descriptors, const Keep& keep,
                  size_t extra_rows, int cols, int type) {
  std::vector<MapPoint> kept;
  std::vector<int> kept_rows;
  kept.reserve(points->size() + extra_rows);
  for (size_t i = 0; i < points->size(); ++i) {
    if (!keep((*points)[i])) continue;
    kept.push_back((*points)[i]);
    kept_rows.push_back(static_cast<int>(i));
  }
  if (kept.size() == points->size() && extra_rows == 0) return kept.size();
  cv::Mat compacted(static_cast<int>(kept.size() + extra_rows), cols, type);
  for (size_t r = 0; r < kept_rows.size(); ++r) {
    descriptors->row(kept_rows[r]).copyTo(compacted.row(static_cast<int>(r)));
  }
  *points = std::move(kept);
  *descriptors = compacted;
  return points->size();
}

}  // namespace

Status LocalMapOptions::Validate() const {
  if (window_keyframes < 1 || window_keyframes > 100) {
    return InvalidArgumentError("local map window_keyframes must be in [1, 100]");
  }
  if (!std::isfinite(depth_sigma_coefficient) || depth_sigma_coefficient <= 0 ||
      !std::isfinite(pixel_sigma) || pixel_sigma <= 0 || !std::isfinite(octave_scale) ||
      octave_scale < 1) {
    return InvalidArgumentError("local map sigmas must be positive (octave_scale >= 1)");
  }
  if (!std::isfinite(min_found_ratio) || min_found_ratio < 0 || min_found_ratio > 1 ||
      min_visible < 1) {
    return InvalidArgumentError("local map min_found_ratio must be in [0, 1] and min_visible >= 1");
  }
  return OkStatus();
}

Eigen::Matrix3d LocalMap::ObservationInformation(const Eigen::Vector3d& p, int octave,
                                                 const Eigen::Matrix3d& R_wc) const {
  // X = ((u - cx) z / fx, (v - cy) z / fy, z): covariance J diag(su^2, sv^2, sz^2) J^T.
  const double z = p.z();
  const double s = options_.pixel_sigma * std::pow(options_.octave_scale, octave);
  const double sz = options_.depth_sigma_coefficient * z * z;
  Eigen::Matrix3d J;
  J << z / camera_.fx, 0, p.x() / z, 0, z / camera_.fy, p.y() / z, 0, 0, 1;
  const Eigen::Matrix3d cov =
      J * Eigen::Vector3d(s * s, s * s, sz * sz).asDiagonal() * J.transpose();
  const Eigen::Matrix3d info_camera = cov.inverse();
  return R_wc * info_camera * R_wc.transpose();
}

void LocalMap::Fuse(MapPoint* mp, const Eigen::Vector3d& x, const Eigen::Matrix3d& info) const {
  mp->information += info;
  mp->information_position += info * x;
  ++mp->num_depth_observations;
  mp->position_world = mp->information.ldlt().solve(mp->information_position);
}

void LocalMap::AddKeyframe(int keyframe_id, const FrameFeatures& f, const Eigen::Isometry3d& T_wc,
                           const std::vector<int>& point_of_keypoint,
                           std::vector<int64_t>* point_ids) {
  const Eigen::Matrix3d R = T_wc.linear();
  std::vector<int> new_keypoints;
  if (point_ids) point_ids->assign(f.size(), -1);
  for (size_t k = 0; k < f.size(); ++k) {
    const int m = point_of_keypoint.empty() ? -1 : point_of_keypoint[k];
    if (m < 0) {
      if (f.has_depth[k]) new_keypoints.push_back(static_cast<int>(k));
      continue;
    }
    MapPoint& mp = points_[static_cast<size_t>(m)];
    if (point_ids) (*point_ids)[k] = mp.id;
    mp.last_keyframe = keyframe_id;
    mp.own = true;
    mp.octave = f.keypoints[k].octave;
    f.descriptors.row(static_cast<int>(k)).copyTo(descriptors_.row(m));
    if (f.has_depth[k]) {
      Fuse(&mp, T_wc * f.points_camera[k],
           ObservationInformation(f.points_camera[k], f.keypoints[k].octave, R));
    }
  }
  // Keep the reliable points of the window, then append the new ones.
  const size_t first_new = KeepPoints(
      &points_, &descriptors_,
      [&](const MapPoint& mp) {
        if (mp.retired || mp.last_keyframe <= keyframe_id - options_.window_keyframes) {
          return false;
        }
        return mp.visible < options_.min_visible ||
               mp.found >= options_.min_found_ratio * mp.visible;
      },
      new_keypoints.size(), f.descriptors.cols, f.descriptors.type());
  for (size_t n = 0; n < new_keypoints.size(); ++n) {
    const size_t k = static_cast<size_t>(new_keypoints[n]);
    MapPoint mp;
    mp.id = next_id_++;
    if (point_ids) (*point_ids)[k] = mp.id;
    mp.last_keyframe = keyframe_id;
    mp.own = true;
    mp.octave = f.keypoints[k].octave;
    Fuse(&mp, T_wc * f.points_camera[k],
         ObservationInformation(f.points_camera[k], f.keypoints[k].octave, R));
    points_.push_back(mp);
    f.descriptors.row(static_cast<int>(k))
        .copyTo(descriptors_.row(static_cast<int>(first_new + n)));
  }
}

void LocalMap::Merge(const LocalMapUpdate& update, const Eigen::Isometry3d& T_new_update,
                     int keyframe_id) {
  if (!update.retired_ids.empty()) {
    const std::unordered_set<int64_t> retired(update.retired_ids.begin(), update.retired_ids.end());
    for (MapPoint& mp : points_) {
      if (retired.count(mp.id) != 0) mp.retired = true;
    }
  }
  const size_t n = update.ids.size();
  if (n == 0 || update.positions_world.size() != n || update.octaves.size() != n ||
      update.descriptors.rows != static_cast<int>(n) ||
      (!descriptors_.empty() && (update.descriptors.cols != descriptors_.cols ||
                                 update.descriptors.type() != descriptors_.type()))) {
    return;
  }
  if (update.refresh) DropUpdateOnlyPointsNotIn(update);
  std::unordered_map<int64_t, size_t> index;
  index.reserve(points_.size());
  for (size_t i = 0; i < points_.size(); ++i) index.emplace(points_[i].id, i);
  std::vector<size_t> added;
  for (size_t u = 0; u < n; ++u) {
    const Eigen::Vector3d p = T_new_update * update.positions_world[u];
    if (!p.allFinite()) continue;
    const auto known = index.find(update.ids[u]);
    if (known != index.end()) {
      MapPoint& mp = points_[known->second];
      mp.position_world = p;
      mp.information_position = mp.information * p;
      continue;
    }
    MapPoint mp;
    mp.id = update.ids[u];
    mp.position_world = p;
    // A refined point is trusted like a few depth observations: sigma ~ 1 cm in every
    // direction until tracking fuses new depth into it.
    mp.information = Eigen::Matrix3d::Identity() * 1e4;
    mp.information_position = mp.information * p;
    mp.num_depth_observations = 1;
    mp.last_keyframe = keyframe_id;
    mp.octave = update.octaves[u];
    index.emplace(mp.id, points_.size());
    points_.push_back(mp);
    added.push_back(u);
  }
  if (added.empty()) return;
  cv::Mat descriptors(static_cast<int>(points_.size()), update.descriptors.cols,
                      update.descriptors.type());
  const int old_rows = static_cast<int>(points_.size() - added.size());
  if (old_rows > 0) descriptors_.rowRange(0, old_rows).copyTo(descriptors.rowRange(0, old_rows));
  for (size_t a = 0; a < added.size(); ++a) {
    update.descriptors.row(static_cast<int>(added[a]))
        .copyTo(descriptors.row(old_rows + static_cast<int>(a)));
  }
  descriptors_ = descriptors;
}

void LocalMap::DropUpdateOnlyPointsNotIn(const LocalMapUpdate& update) {
  const std::unordered_set<int64_t> in_update(update.ids.begin(), update.ids.end());
  KeepPoints(
      &points_, &descriptors_,
      [&](const MapPoint& mp) { return mp.own || in_update.count(mp.id) != 0; },
      /*extra_rows=*/0, descriptors_.cols, descriptors_.type());
}

void LocalMap::CountTracked(const std::vector<int>& visible, const std::vector<int>& found,
                            int64_t frame) {
  for (int i : visible) ++points_[static_cast<size_t>(i)].visible;
  for (int i : found) {
    MapPoint& mp = points_[static_cast<size_t>(i)];
    ++mp.found;
    mp.last_found_frame = frame;
  }
}

void LocalMap::Transform(const Eigen::Isometry3d& T) {
  const Eigen::Matrix3d R = T.linear();
  for (MapPoint& mp : points_) {
    mp.position_world = T * mp.position_world;
    mp.information = R * mp.information * R.transpose();
    mp.information_position = mp.information * mp.position_world;
  }
}

void LocalMap::Clear() {
  points_.clear();
  descriptors_ = cv::Mat();
}

}  // namespace semmap
