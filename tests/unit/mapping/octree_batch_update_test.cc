// internal::ComputeScanUpdates / ApplyCellUpdates against OctoMap's own path: the same voxels
// as computeUpdate, and byte for byte the same tree as updateNode per voxel, over keyframes of
// the synthetic room inserted again and again (clamping, early aborts, pruning, expansion).
#include "core/mapping/internal/octree_batch_update.h"

#include <gtest/gtest.h>
#include <octomap/ColorOcTree.h>

#include <algorithm>
#include <cstdlib>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/mapping/occupancy_map.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/room_circle.h"

namespace semmap {
namespace {

constexpr double kResolution = 0.05;
constexpr double kMaxRange = 4.0;

struct Scan {
  octomap::Pointcloud points;  // world frame
  octomap::point3d origin;
};

// Every `every`-th pose of a 120-frame circle through the synthetic room: its depth as world
// points (every 4th pixel, as semmapd keeps them), some beyond the range limit.
std::vector<Scan> RoomScans(int every) {
  StatusOr<synth::RoomCircle> circle = synth::RenderRoomCircle(120, every);
  if (!circle.ok()) std::abort();
  OccupancyMapOptions options;
  options.max_range_m = 50;  // keep the far points: the scan's range limit is tested here
  std::vector<Scan> out;
  for (const synth::RoomView& view : circle->views) {
    const Eigen::Isometry3d& T = view.T_world_camera;
    StatusOr<KeyframeCloud> cloud = MakeKeyframeCloud({view.frame.depth, synth::kDepthScale},
                                                      view.frame.bgr, circle->camera, options);
    if (!cloud.ok()) std::abort();
    Scan scan;
    for (const Eigen::Vector3f& p : cloud->points) {
      const Eigen::Vector3f w = (T.cast<float>() * p);
      scan.points.push_back(octomap::point3d(w.x(), w.y(), w.z()));
    }
    const Eigen::Vector3d t = T.translation();
    scan.origin = octomap::point3d(static_cast<float>(t.x()), static_cast<float>(t.y()),
                                   static_cast<float>(t.z()));
    out.push_back(std::move(scan));
  }
  return out;
}

const std::vector<Scan>& Scans() {
  static const std::vector<Scan>* const scans = new std::vector<Scan>(RoomScans(15));
  return *scans;
}

// The scan's distinct end voxels' centres, as computeDiscreteUpdate makes them.
octomap::Pointcloud Discretized(const octomap::ColorOcTree& tree, const octomap::Pointcloud& scan) {
  octomap::KeySet seen;
  octomap::Pointcloud out;
  for (const octomap::point3d& p : scan) {
    const octomap::OcTreeKey key = tree.coordToKey(p);
    if (seen.insert(key).second) out.push_back(tree.keyToCoord(key));
  }
  return out;
}

std::vector<uint64_t> Codes(const octomap::KeySet& keys) {
  std::vector<uint64_t> out;
  for (const octomap::OcTreeKey& k : keys) out.push_back(internal::Morton(k));
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<uint64_t> Codes(const std::vector<internal::CellUpdate>& updates, bool occupied) {
  std::vector<uint64_t> out;
  for (const internal::CellUpdate& u : updates) {
    if (u.occupied == occupied) out.push_back(u.code);
  }
  return out;
}

std::string Bytes(const octomap::ColorOcTree& tree) {
  std::ostringstream out;
  tree.write(out);
  return out.str();
}

void ExpectSameVoxels(octomap::ColorOcTree& tree, const octomap::Pointcloud& scan,
                      const octomap::point3d& origin, double max_range) {
  octomap::KeySet free_cells, occupied_cells;
  tree.computeUpdate(scan, origin, free_cells, occupied_cells, max_range);
  const std::vector<internal::CellUpdate> updates =
      internal::ComputeScanUpdates(tree, scan, origin, max_range);
  EXPECT_TRUE(std::is_sorted(updates.begin(), updates.end(),
                             [](const internal::CellUpdate& a, const internal::CellUpdate& b) {
                               return a.code < b.code;
                             }));
  EXPECT_EQ(Codes(updates, /*occupied=*/false), Codes(free_cells));
  EXPECT_EQ(Codes(updates, /*occupied=*/true), Codes(occupied_cells));
  EXPECT_EQ(updates.size(), free_cells.size() + occupied_cells.size());  // each key once
  for (const internal::CellUpdate& u : updates) {
    ASSERT_EQ(internal::Morton(u.key), u.code);  // the key goes with its code
  }
}

TEST(OctreeBatchUpdateTest, MortonGivesTheChildIndexAtEveryLevel) {
  const octomap::OcTreeKey key(0xA5C3, 0x0F0F, 0x1234);
  const uint64_t code = internal::Morton(key);
  for (unsigned level = 0; level < 16; ++level) {
    EXPECT_EQ((code >> (3 * level)) & 7, octomap::computeChildIdx(key, static_cast<int>(level)))
        << "level " << level;
  }
}

TEST(OctreeBatchUpdateTest, SameVoxelsAsComputeUpdate) {
  octomap::ColorOcTree tree(kResolution);
  for (const Scan& scan : Scans()) {
    SCOPED_TRACE("scan from (" + std::to_string(scan.origin.x()) + ", " +
                 std::to_string(scan.origin.y()) + ")");
    ExpectSameVoxels(tree, Discretized(tree, scan.points), scan.origin, kMaxRange);
    ExpectSameVoxels(tree, scan.points, scan.origin, kMaxRange);  // every point, duplicates
    ExpectSameVoxels(tree, scan.points, scan.origin, 1.5);        // many beyond the range
    ExpectSameVoxels(tree, scan.points, scan.origin, -1);         // no range limit
  }
}

TEST(OctreeBatchUpdateTest, EmptyScanHasNoUpdatesAndChangesNothing) {
  octomap::ColorOcTree tree(kResolution);
  EXPECT_TRUE(internal::ComputeScanUpdates(tree, {}, octomap::point3d(0, 0, 0), kMaxRange).empty());
  internal::ApplyCellUpdates(tree, {});
  EXPECT_EQ(tree.getRoot(), nullptr);
  EXPECT_EQ(tree.size(), 0U);
}

// Both trees get the same scans; each insertion must leave them byte for byte equal. Inserting
// every scan three times saturates free space and walls (clamped values, skipped updates),
// prunes uniform regions and expands pruned ones again when a later ray disagrees.
TEST(OctreeBatchUpdateTest, SameTreeAsUpdateNodePerVoxel) {
  octomap::ColorOcTree reference(kResolution), batched(kResolution);
  size_t insertions = 0;
  for (int round = 0; round < 3; ++round) {
    for (const Scan& scan : Scans()) {
      const octomap::Pointcloud centres = Discretized(reference, scan.points);
      octomap::KeySet free_cells, occupied_cells;
      reference.computeUpdate(centres, scan.origin, free_cells, occupied_cells, kMaxRange);
      for (const octomap::OcTreeKey& k : free_cells) reference.updateNode(k, false, false);
      for (const octomap::OcTreeKey& k : occupied_cells) reference.updateNode(k, true, false);
      internal::ApplyCellUpdates(
          batched, internal::ComputeScanUpdates(batched, centres, scan.origin, kMaxRange));
      ++insertions;
      ASSERT_EQ(batched.size(), reference.size()) << "after insertion " << insertions;
      ASSERT_EQ(Bytes(batched), Bytes(reference)) << "after insertion " << insertions;
    }
  }
  // The test reached what it is about: pruned nodes (fewer nodes than leaves would need).
  size_t leaves_at_bottom = 0, leaves = 0;
  for (auto it = batched.begin_leafs(), end = batched.end_leafs(); it != end; ++it) {
    ++leaves;
    if (it.getDepth() == 16) ++leaves_at_bottom;
  }
  EXPECT_LT(leaves_at_bottom, leaves);
}

// Random updates in a small cube, with repeats across rounds and both directions mixed: every
// branch of the descent (new nodes, existing ones, pruned ones at several depths).
TEST(OctreeBatchUpdateTest, RandomUpdatesInASmallCube) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> coordinate(32768 - 6, 32768 + 5);
  std::bernoulli_distribution occupied(0.3);
  octomap::ColorOcTree reference(kResolution), batched(kResolution);
  for (int round = 0; round < 60; ++round) {
    std::vector<internal::CellUpdate> updates;
    octomap::KeySet seen;
    for (int i = 0; i < 200; ++i) {
      const octomap::OcTreeKey key(static_cast<octomap::key_type>(coordinate(rng)),
                                   static_cast<octomap::key_type>(coordinate(rng)),
                                   static_cast<octomap::key_type>(coordinate(rng)));
      if (!seen.insert(key).second) continue;
      updates.push_back({internal::Morton(key), key, occupied(rng)});
    }
    for (const internal::CellUpdate& u : updates) reference.updateNode(u.key, u.occupied, false);
    std::sort(updates.begin(), updates.end(),
              [](const internal::CellUpdate& a, const internal::CellUpdate& b) {
                return a.code < b.code;
              });
    internal::ApplyCellUpdates(batched, updates);
    ASSERT_EQ(Bytes(batched), Bytes(reference)) << "after round " << round;
  }
}

}  // namespace
}  // namespace semmap
