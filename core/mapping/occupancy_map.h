// Occupancy map of one semantic map: an OctoMap ColorOcTree built from keyframe depth and colour.
//
// Each keyframe contributes a KeyframeCloud kept in the keyframe's own camera frame, so a
// pose-graph correction only needs the keyframes' new poses: OccupancyMap::Build() makes a
// fresh tree from the clouds at the corrected poses (the caller swaps it in when done).
//
// Colour: after a keyframe's ray casting, the mean colour of the keyframe's points in each end
// voxel is averaged into that voxel (ColorOcTree::averageNodeColor: new = (old + mean) / 2, so
// repeated observations converge), then inner nodes get their children's mean colour. OctoMap
// treats pure white (255, 255, 255) as "no colour yet", so white voxels may be uncoloured ones.
//
// Persistence: SerializeOt() writes the full-probability ColorOcTree .ot form with
// AbstractOcTree::write(), which leaves the live tree untouched (OctoMap's writeBinary() would
// prune it). DeserializeOt() checks the header and walks the whole node stream itself before
// handing it to OctoMap, whose reader trusts its input (truncated files load silently, garbage
// can recurse without bound); plain OcTree .ot files load too (uncoloured, i.e. white). Blobs
// are additionally checksummed by the store (MapStore::GetBlob, DATA_LOSS). The .bt export
// (SerializeBt) is an OcTree without colour: the format has none.
//
// OctoMap stays out of this header. Not thread-safe: one writer, or readers only.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/camera.h"
#include "common/cancel_check.h"
#include "common/status.h"
#include "core/sensor/image_decoding.h"

namespace octomap {
class ColorOcTree;
}  // namespace octomap

namespace semmap {

struct OccupancyMapOptions {
  double resolution_m = 0.05;  // leaf voxel edge
  double max_range_m = 4.0;    // points farther from the camera are dropped
  int pixel_step = 4;          // use every pixel_step-th depth pixel in x and y
  bool discretize = true;      // OctoMap's fast insertion (one ray per end voxel)
  // Each keyframe cloud is reduced to one point (the mean, with the mean colour) per cube of
  // this edge in the keyframe's frame, 0 for every pixel. What a map keeps per keyframe for its
  // rebuilds: near surfaces give many points per occupancy voxel that the tree merges anyway.
  // semmapd uses 0.02 (--map-keyframe-voxel).
  double keyframe_voxel_m = 0;

  // resolution in [1 mm, 1 m], max range in (0, 50] m, pixel step in [1, 64], keyframe voxel
  // 0 or in [1 mm, resolution], all finite.
  Status Validate() const;
};

// One keyframe's depth as points in the keyframe's camera frame (x right, y down, z forward).
struct KeyframeCloud {
  std::vector<Eigen::Vector3f> points;          // metres, camera frame
  std::vector<std::array<uint8_t, 3>> colours;  // BGR, one per point

  size_t size() const { return points.size(); }
};

// Back-projects every pixel_step-th pixel (starting at pixel_step / 2) with valid depth
// within max_range_m (Euclidean distance from the camera), then keeps one mean point per
// keyframe_voxel_m cube when that is set (in the order the cubes were first hit). `bgr` is CV_8UC3
// (or CV_8UC1 grey) of the depth's size; the calibration's size must match too. Distortion is
// undone iteratively. INVALID_ARGUMENT for a wrong type, size, scale or calibration.
StatusOr<KeyframeCloud> MakeKeyframeCloud(const DecodedDepth& depth, const cv::Mat& bgr,
                                          const CameraCalibration& camera,
                                          const OccupancyMapOptions& options);

// What the tree knows about a point.
enum class VoxelState { kUnknown, kFree, kOccupied };

class OccupancyMap {
 public:
  struct Voxel {
    Eigen::Vector3d centre;
    double size = 0;               // edge, metres (larger than the resolution for pruned nodes)
    float log_odds = 0;            // OctoMap's stored value
    std::array<uint8_t, 3> rgb{};  // node colour, RGB (white where none was integrated)
  };

  // An empty map. INVALID_ARGUMENT for bad options.
  static StatusOr<OccupancyMap> Create(const OccupancyMapOptions& options);
  // A fresh map from keyframes at the given poses, inserted in order (the rebuild after a
  // loop closure). INVALID_ARGUMENT for bad options, a null cloud or a non-finite pose;
  // `cancel`'s status when it answers one (asked before each keyframe).
  static StatusOr<OccupancyMap> Build(
      const std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>>& keyframes,
      const OccupancyMapOptions& options, const CancelCheck& cancel = {});
  // The same from `count` keyframes handed over one at a time, so that a map need not hold every
  // cloud at once (the layers read evicted ones back from the store while they rebuild):
  // `keyframe(i)` gives keyframe i's cloud and pose; it runs in index order on the build's
  // ray-casting thread, at most a few keyframes ahead of the tree, and its error ends the build.
  // `inserted(i, cloud)`, when given, runs on the calling thread once keyframe i is in the tree.
  using KeyframeSource =
      std::function<StatusOr<std::pair<std::shared_ptr<const KeyframeCloud>, Eigen::Isometry3d>>(
          size_t)>;
  using KeyframeInserted = std::function<void(size_t, const std::shared_ptr<const KeyframeCloud>&)>;
  static StatusOr<OccupancyMap> Build(size_t count, const KeyframeSource& keyframe,
                                      const OccupancyMapOptions& options,
                                      const CancelCheck& cancel = {},
                                      const KeyframeInserted& inserted = {});

  OccupancyMap(OccupancyMap&&) noexcept;
  OccupancyMap& operator=(OccupancyMap&&) noexcept;
  OccupancyMap(const OccupancyMap&) = delete;
  OccupancyMap& operator=(const OccupancyMap&) = delete;
  ~OccupancyMap();

  // Ray-casts the cloud from the keyframe's origin: free along each ray, occupied at the end,
  // then averages the points' colours into their end voxels. INVALID_ARGUMENT for a non-finite
  // pose or a cloud whose colour count differs from its point count, OUT_OF_RANGE for a pose
  // outside the tree's extent.
  Status Insert(const KeyframeCloud& cloud, const Eigen::Isometry3d& T_world_keyframe);

  // kUnknown outside the tree's range or where no ray has passed.
  VoxelState Occupancy(const Eigen::Vector3d& p_world) const;
  // RGB colour of the occupied leaf at the point; nullopt where Occupancy() is not kOccupied.
  std::optional<std::array<uint8_t, 3>> ColourAt(const Eigen::Vector3d& p_world) const;

  size_t size() const;         // tree nodes (inner and leaves)
  size_t MemoryBytes() const;  // OctoMap's estimate of the tree's memory
  double KnownVolume() const;  // m^3 of free or occupied leaves (what memory per m^3 divides by)
  // Bounds of the known (free or occupied) space; empty when the map is.
  Eigen::AlignedBox3d Bounds() const;
  // Occupied leaves (pruned ones are bigger than the resolution), in tree order.
  std::vector<Voxel> OccupiedVoxels() const;
  double resolution() const { return options_.resolution_m; }
  const OccupancyMapOptions& options() const { return options_; }

  // Full-probability .ot bytes; never prunes or otherwise changes the tree.
  StatusOr<std::string> SerializeOt() const;
  // Reads SerializeOt() bytes (a ColorOcTree .ot) or a plain OcTree .ot (loaded with the same
  // occupancy, uncoloured). The resolution comes from the bytes and overrides
  // options.resolution_m. INVALID_ARGUMENT for something that is not an .ot of either type,
  // DATA_LOSS for a damaged one (truncated, inconsistent, non-finite values).
  static StatusOr<OccupancyMap> DeserializeOt(std::string_view ot,
                                              OccupancyMapOptions options = {});
  // Maximum-likelihood binary .bt (an OcTree, no colour) of a pruned copy, for export; the
  // live tree is untouched.
  StatusOr<std::string> SerializeBt() const;

 private:
  OccupancyMap(std::unique_ptr<octomap::ColorOcTree> tree, const OccupancyMapOptions& options);

  std::unique_ptr<octomap::ColorOcTree> tree_;
  OccupancyMapOptions options_;
};

}  // namespace semmap
