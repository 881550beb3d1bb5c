// One keyframe's occupancy update as a batch: the voxels its rays pass through and end in
// (what OccupancyOcTreeBase::computeDiscreteUpdate finds), applied to the tree in one descent
// (what calling updateNode(key, occupied) once per voxel leaves behind). OctoMap's own path
// collects the voxels in a node-based hash set and descends from the root twice per voxel
// (an early-abort search, then the update), pruning and recomputing every inner node on the way
// up each time: most of an insertion's cost on a 16-level tree. Internal to core/mapping.
#pragma once

#include <octomap/ColorOcTree.h>

#include <cstdint>
#include <vector>

namespace semmap::internal {

// Morton code of a key: bit i of k[c] at bit 3i + c. Sorted by code, the voxels under any
// tree node are adjacent, and (code >> 3 * level) & 7 is the child index at that level.
uint64_t Morton(const octomap::OcTreeKey& key);

// One leaf voxel to update: seen free (a ray passed through) or occupied (a ray ended in it).
struct CellUpdate {
  uint64_t code;  // Morton(key)
  octomap::OcTreeKey key;
  bool occupied;
};

// The updates of `scan` (world points) seen from `origin`: for each point, a ray from the
// origin to it whose voxels are free and whose end voxel is occupied; points farther than
// `max_range_m` (< 0: no limit) give a ray of that length and no occupied voxel; a voxel both
// free and occupied is occupied. The same voxels as tree.computeUpdate(scan, origin, free,
// occupied, max_range_m) (computeDiscreteUpdate is this on the centres of the scan's distinct
// end voxels), sorted by code, each once. Reads only the tree's resolution and extent.
std::vector<CellUpdate> ComputeScanUpdates(const octomap::ColorOcTree& tree,
                                           const octomap::Pointcloud& scan,
                                           const octomap::point3d& origin, double max_range_m);

// Applies `updates` (sorted by code, each key once) with the tree's hit/miss log-odds and
// clamping: the same tree (nodes, values, colours, pruning) as tree.updateNode(key, occupied,
// /*lazy_eval=*/false) for each of them in any order, visiting each node on their paths once.
void ApplyCellUpdates(octomap::ColorOcTree& tree, const std::vector<CellUpdate>& updates);

}  // namespace semmap::internal
