// Coloured point cloud of one semantic map: keyframe clouds at their poses, merged and
// voxel-grid filtered with PCL (pcl::VoxelGrid<pcl::PointXYZRGB>, positions and colours
// averaged per leaf).
//
// Like OccupancyMap, the map is a pure function of the keyframe clouds (each in its own camera
// frame, see KeyframeCloud) and their poses: after a pose-graph correction the caller calls
// Build() again with the corrected poses and swaps the result in.
//
// The leaf grid is anchored at the world origin (leaf boundaries at multiples of leaf_size_m),
// so the same surface seen by several keyframes lands in the same leaves. Very large extents
// (more leaves than PCL's 32-bit voxel index holds) are filtered in slabs along x, with the
// same result.
//
// Exports are written here into memory (no temporary files), so the server can stream them:
// PLY (x y z float, red green blue uchar) and PCD v0.7 (x y z float, rgb a packed uint32),
// binary little-endian or ASCII. Both read back with pcl::io into pcl::PointXYZRGB.
//
// PCL stays out of this header. The map is an immutable value after Build(): safe to read
// from several threads.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "common/cancel_check.h"
#include "common/status.h"
#include "core/mapping/cloud_point.h"
#include "core/mapping/occupancy_map.h"

namespace semmap {

// Leaf index along one axis exactly as PCL's VoxelGrid computes it (float arithmetic): the grid
// the cloud layer, its incremental form and their tests share. |coordinate * inverse_leaf| must
// be below 2^63.
inline int64_t PclLeafIndex(float coordinate, float inverse_leaf) {
  return static_cast<int64_t>(std::floor(coordinate * inverse_leaf));
}

struct PointCloudMapOptions {
  double leaf_size_m = 0.02;  // voxel-grid leaf edge
  // Build() filters at most this many world points at once (slabs along x beyond it), so a map
  // of many keyframes is not held again as one PCL cloud of 32 bytes a point.
  size_t max_points_per_piece = size_t{4} << 20;

  // leaf size finite and in [1 mm, 1 m]; at least 1000 points per piece.
  Status Validate() const;
};

class PointCloudMap {
 public:
  // An empty map.
  PointCloudMap() = default;

  // Transforms each cloud by its T_world_keyframe, concatenates and voxel-grid filters: one
  // point per occupied leaf, at the mean of its points, with the mean colour per channel
  // (truncated to an integer, as PCL does). Non-finite points are dropped. INVALID_ARGUMENT
  // for bad options, a null cloud, a colour count that differs from the point count or a
  // non-finite pose; INTERNAL if PCL throws; RESOURCE_EXHAUSTED when out of memory; `cancel`'s
  // status when it answers one (asked before each pass over the points).
  static StatusOr<PointCloudMap> Build(
      const std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>>& keyframes,
      const PointCloudMapOptions& options, const CancelCheck& cancel = {});

  // A map read back from its stored form (ReadCloudPcd): the points as they are, no filtering.
  static PointCloudMap FromPoints(std::vector<CloudPoint> points,
                                  const PointCloudMapOptions& options) {
    return PointCloudMap(std::move(points), options);
  }

  size_t size() const { return points_.size(); }
  bool empty() const { return points_.empty(); }
  // In PCL's voxel order (not spatially meaningful beyond that).
  const std::vector<CloudPoint>& points() const { return points_; }
  // Bounds of the filtered points; empty (isEmpty()) when the map is.
  Eigen::AlignedBox3d Bounds() const;
  const PointCloudMapOptions& options() const { return options_; }

  // PLY 1.0, one "vertex" element: float x y z, uchar red green blue. `binary` selects
  // binary_little_endian (the default for export), otherwise ascii. Floats in ASCII are
  // written in shortest round-trip form.
  StatusOr<std::string> ToPly(bool binary = true) const;
  // PCD v0.7, FIELDS x y z rgb, rgb TYPE U holding 0xAARRGGBB with alpha 255 (PCL 1.13 reads
  // it into PointXYZRGB; TYPE F, PCL's own choice, does not survive PCL's ASCII reader),
  // WIDTH = POINTS = size, HEIGHT 1. `binary` selects DATA binary, otherwise DATA ascii.
  StatusOr<std::string> ToPcd(bool binary = true) const;

 private:
  PointCloudMap(std::vector<CloudPoint> points, const PointCloudMapOptions& options)
      : points_(std::move(points)), options_(options) {}

  std::vector<CloudPoint> points_;
  PointCloudMapOptions options_;
};

}  // namespace semmap
