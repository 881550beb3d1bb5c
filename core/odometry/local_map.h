// The tracker's local map: 3D points (world frame) of the last few keyframes, each with the
// descriptor of its latest observation and a position fused from every depth observation
// (information-weighted: precise across the viewing ray, sigma_z ~ c z^2 along it).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <unordered_map>
#include <vector>

#include "common/camera.h"
#include "common/status.h"
#include "core/sensor/frame_features.h"

namespace semmap {

struct LocalMapOptions {
  // A point stays while one of the last this many keyframes observed it.
  int window_keyframes = 8;
  double depth_sigma_coefficient = 1.5e-3;  // sigma_z = c * z^2 (metres)
  double pixel_sigma = 1.0;                 // keypoint sigma at octave 0
  double octave_scale = 1.2;  // ... times this per pyramid level (features.orb_scale_factor)
  // Points predicted in view at least min_visible times but matched in fewer than this
  // fraction of those frames are dropped (bad depth, repeated texture).
  double min_found_ratio = 0.25;
  int min_visible = 8;

  Status Validate() const;
};

struct MapPoint {
  int64_t id = 0;  // unique for the tracker's lifetime (the back end's map points follow it)
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  // Sums over the depth observations: information (world frame) and information * position.
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  Eigen::Vector3d information_position = Eigen::Vector3d::Zero();
  int num_depth_observations = 0;
  int last_keyframe = -1;         // id of the newest keyframe that observed it
  int octave = 0;                 // pyramid level of the newest observation
  int visible = 0;                // frames that predicted it in view
  int found = 0;                  // ... and matched it as an inlier
  int64_t last_found_frame = -1;  // the tracker's number of the last frame that found it
  bool own = false;  // observed by one of the tracker's keyframes (else known from updates only)
  // The back end fused it into another point (published under that point's id): it is no
  // longer projected or matched, and goes at the next keyframe.
  bool retired = false;
};

// Points of the back end's map for a session's tracker (after each local bundle adjustment):
// the points its covisible and nearby keyframes observe, with refined positions. Ids are the
// tracker's own (MapPoint::id), so points it forgot come back under the same id and new
// observations of them join the same back-end point.
struct LocalMapUpdate {
  std::vector<int64_t> ids;
  std::vector<Eigen::Vector3d> positions_world;
  std::vector<int> octaves;  // of the observation the descriptor comes from
  cv::Mat descriptors;       // one row per point
  // Tracker ids of this session fused into one of the points above: without retiring them the
  // tracker would keep matching a stale copy of each fused point beside the refined one.
  std::vector<int64_t> retired_ids;
  // Poses of the keyframes (any session's) the points come from: the views the map already
  // has around the tracker (KeyframeCandidate::mapped_keyframes).
  std::vector<Eigen::Isometry3d> keyframe_poses_world;
  // Sent because the camera moved on through mapped keyframes without making any (a revisit),
  // not after a new keyframe: the points earlier updates brought that this one does not have
  // and that none of the tracker's keyframes observed go, so the local map follows the camera
  // through the mapped place instead of growing with it.
  bool refresh = false;
};

class LocalMap {
 public:
  // `camera`: the intrinsics of the keypoints (for the observation information).
  LocalMap(LocalMapOptions options, CameraCalibration camera)
      : options_(options), camera_(camera) {}

  size_t size() const { return points_.size(); }
  const MapPoint& point(size_t i) const { return points_[i]; }
  // Row i: the descriptor of point i.
  const cv::Mat& descriptors() const { return descriptors_; }

  // Keyframe `keyframe_id` (increasing) with `features` at T_world_camera. `point_of_keypoint`
  // (empty, or one entry per keypoint): the map point each keypoint was matched to as an
  // inlier, -1 for none. Matched keypoints refresh their point's descriptor and fuse their
  // depth into it; unmatched keypoints with depth become new points. Points outside the
  // keyframe window and unreliable points are dropped (indices change). `point_ids` (may be
  // null) receives, per keypoint, the id of the point it matched or started, -1 for none.
  void AddKeyframe(int keyframe_id, const FrameFeatures& features,
                   const Eigen::Isometry3d& T_world_camera,
                   const std::vector<int>& point_of_keypoint,
                   std::vector<int64_t>* point_ids = nullptr);

  // Bookkeeping of tracked frame number `frame`: points predicted in view and points found
  // (inliers).
  void CountTracked(const std::vector<int>& visible, const std::vector<int>& found, int64_t frame);

  // Takes the back end's points (positions re-expressed as T_new_update * p): known ids move
  // to the refined position, unknown ones are added as observed by keyframe `keyframe_id` (so
  // they stay for the window unless tracking finds them again); retired ids are retired. A
  // refresh (LocalMapUpdate::refresh) drops the update-only points it does not hold.
  void Merge(const LocalMapUpdate& update, const Eigen::Isometry3d& T_new_update, int keyframe_id);

  // Re-expresses every point as T_new_world * point.
  void Transform(const Eigen::Isometry3d& T_new_world);

  void Clear();

 private:
  // Information (world frame) of a keypoint's back-projection.
  Eigen::Matrix3d ObservationInformation(const Eigen::Vector3d& p_camera, int octave,
                                         const Eigen::Matrix3d& R_world_camera) const;
  void Fuse(MapPoint* point, const Eigen::Vector3d& p_world, const Eigen::Matrix3d& info) const;
  // LocalMapUpdate::refresh: forgets the points only updates brought that `update` lacks.
  void DropUpdateOnlyPointsNotIn(const LocalMapUpdate& update);

  LocalMapOptions options_;
  CameraCalibration camera_;
  std::vector<MapPoint> points_;
  cv::Mat descriptors_;
  int64_t next_id_ = 0;  // never reset (Clear keeps counting)
};

}  // namespace semmap
