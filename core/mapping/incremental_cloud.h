// The coloured cloud layer of a map kept current one keyframe at a time. Per leaf of
// PointCloudMap's grid (anchored at the origin, boundaries at multiples of leaf_size_m, the index
// computed in float as PCL's VoxelGrid does) it holds the sums of the positions and colours of
// the points in the leaf and their count. Snapshot() is what PointCloudMap::Build makes of the
// same keyframes: the same leaves, each point at the mean of the leaf's points (the means agree
// to float precision: PCL sums in another order) with the mean colour truncated.
//
// A keyframe added at a pose comes out again exactly when removed at that pose: the sums are
// integers (positions in 1/65536 of a leaf from its centre, 0.3 um at 2 cm; colours; counts), so
// nothing drifts however often keyframes are moved, and a leaf whose count reaches 0 is gone. The
// map layers therefore move the keyframes a correction moves instead of filtering every
// keyframe's points again at each persist: the work no longer grows with the map, and the table
// is bounded by the space seen, not by how long it was streamed (48 bytes a slot, at most 7/8
// full). A leaf takes at most 2^24 points (16.7 million: a 2 cm spot seen by millions of
// keyframes); points beyond that are left out and counted (points_saturated()).
//
// Not thread-safe: one writer (the map's layer builder).
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "common/status.h"
#include "core/mapping/occupancy_map.h"
#include "core/mapping/point_cloud_map.h"

namespace semmap {

class IncrementalCloud {
 public:
  // Leaf indices a key holds along each axis: [-kIndexReach, kIndexReach).
  static constexpr int64_t kIndexReach = int64_t{1} << 20;
  // How far from the origin that reaches along each axis.
  static double ReachM(const PointCloudMapOptions& options) {
    return options.leaf_size_m * static_cast<double>(kIndexReach);
  }

  // An empty cloud. INVALID_ARGUMENT for bad options.
  static StatusOr<IncrementalCloud> Create(const PointCloudMapOptions& options);

  // Adds the cloud's finite points at the pose. Points whose leaf index is beyond ±2^20 along an
  // axis (20 km at the 2 cm default) are left out and counted in points_out_of_range().
  // INVALID_ARGUMENT for a colour count that differs from the point count or a non-finite pose.
  Status Add(const KeyframeCloud& cloud, const Eigen::Isometry3d& T_world_keyframe);
  // Takes out what Add(cloud, T_world_keyframe) put in. FAILED_PRECONDITION when the cloud was
  // not added at that pose (a leaf it needs is missing or too small): the sums are then partly
  // changed, and the caller rebuilds them with Clear() and Add().
  Status Remove(const KeyframeCloud& cloud, const Eigen::Isometry3d& T_world_keyframe);
  void Clear();

  // One point per leaf, in the table's order (the same for the same history of calls).
  PointCloudMap Snapshot() const;

  size_t size() const { return size_; }  // leaves
  size_t MemoryBytes() const { return slots_.capacity() * sizeof(Slot); }
  uint64_t points_out_of_range() const { return points_out_of_range_; }
  uint64_t points_saturated() const { return points_saturated_; }
  const PointCloudMapOptions& options() const { return options_; }

 private:
  // A leaf's sums in an open-addressing table (linear probing). One flat array, key beside its
  // sums: a lookup touches one cache line, a snapshot reads the array front to back (measured:
  // keys and sums in two arrays made moving a keyframe ~2x slower).
  struct Slot {
    uint64_t key;                 // packed leaf index; kEmpty: a free slot
    int64_t x = 0, y = 0, z = 0;  // offsets from the leaf's centre in 1/65536 leaf, summed
    uint32_t r = 0, g = 0, b = 0;
    uint32_t count = 0;
  };
  static constexpr uint64_t kEmpty = ~uint64_t{0};  // packed keys use 63 bits

  explicit IncrementalCloud(const PointCloudMapOptions& options) : options_(options) {}
  size_t Home(uint64_t key) const;
  size_t Find(uint64_t key) const;    // the key's index, or kNotFound
  size_t FindOrInsert(uint64_t key);  // grows the table first when it is 7/8 full
  void Erase(size_t index);           // backward-shift deletion: no tombstones
  void Grow();
  static constexpr size_t kNotFound = ~size_t{0};

  // Visits each finite point's packed leaf key, quantised offset from the leaf's centre and
  // colour (RGB); points beyond the key's range are counted in `out_of_range` instead.
  template <typename Visit>
  Status ForEachPoint(const KeyframeCloud& cloud, const Eigen::Isometry3d& T_world_keyframe,
                      uint64_t* out_of_range, Visit&& visit);

  PointCloudMapOptions options_;
  std::vector<Slot> slots_;  // a power of two long, or empty
  size_t size_ = 0;
  uint64_t points_out_of_range_ = 0;
  uint64_t points_saturated_ = 0;
};

}  // namespace semmap
