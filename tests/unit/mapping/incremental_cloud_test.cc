// IncrementalCloud (core/mapping) against PointCloudMap::Build (PCL's voxel grid) on synthetic
// room keyframes, and its add / remove bookkeeping.
#include "core/mapping/incremental_cloud.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <utility>
#include <vector>

#include "tests/testing/same_cloud.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/room_circle.h"

namespace semmap {
namespace {

struct Keyframe {
  KeyframeCloud cloud;
  Eigen::Isometry3d T_world_camera;
};

// Every 10th pose of a 120-frame circle through the room, clouds as semmapd keeps them.
const std::vector<Keyframe>& RoomKeyframes() {
  static const std::vector<Keyframe>* const keyframes = [] {
    StatusOr<synth::RoomCircle> circle = synth::RenderRoomCircle(120, 10);
    if (!circle.ok()) std::abort();
    OccupancyMapOptions options;
    options.keyframe_voxel_m = 0.02;
    auto* out = new std::vector<Keyframe>;
    for (const synth::RoomView& view : circle->views) {
      StatusOr<KeyframeCloud> cloud = MakeKeyframeCloud({view.frame.depth, synth::kDepthScale},
                                                        view.frame.bgr, circle->camera, options);
      if (!cloud.ok()) std::abort();
      out->push_back({std::move(cloud).value(), view.T_world_camera});
    }
    return out;
  }();
  return *keyframes;
}

IncrementalCloud MakeCloud() {
  StatusOr<IncrementalCloud> cloud = IncrementalCloud::Create({});
  if (!cloud.ok()) std::abort();
  return std::move(cloud).value();
}

using testing::ExpectSameCloud;
constexpr double kLeaf = 0.02;  // PointCloudMapOptions' default

TEST(IncrementalCloudTest, SameLeavesAndMeansAsPclsVoxelGrid) {
  IncrementalCloud cloud = MakeCloud();
  std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> all;
  for (const Keyframe& k : RoomKeyframes()) {
    ASSERT_TRUE(cloud.Add(k.cloud, k.T_world_camera).ok());
    all.emplace_back(&k.cloud, k.T_world_camera);
  }
  StatusOr<PointCloudMap> reference = PointCloudMap::Build(all, {});
  ASSERT_TRUE(reference.ok());
  const PointCloudMap snapshot = cloud.Snapshot();
  EXPECT_GT(snapshot.size(), 10000u);
  EXPECT_EQ(cloud.size(), snapshot.size());
  // PCL sums in float: its means are within a few float steps of the exact ones; its colour
  // means are truncated from float sums, ours from integer ones.
  ExpectSameCloud(snapshot.points(), reference->points(), kLeaf, 2e-6, 1);
  EXPECT_EQ(cloud.points_out_of_range(), 0u);
  // 48-byte slots, the table at most 7/8 full and at least 7/16 after it doubled.
  EXPECT_GE(cloud.MemoryBytes(), cloud.size() * 48 * 8 / 7);
  EXPECT_LE(cloud.MemoryBytes(), cloud.size() * 48 * 16 / 7);
}

TEST(IncrementalCloudTest, RemovingAKeyframeLeavesWhatTheOthersMake) {
  const std::vector<Keyframe>& keyframes = RoomKeyframes();
  IncrementalCloud all = MakeCloud(), without_first = MakeCloud();
  for (size_t i = 0; i < keyframes.size(); ++i) {
    ASSERT_TRUE(all.Add(keyframes[i].cloud, keyframes[i].T_world_camera).ok());
    if (i > 0) {
      ASSERT_TRUE(without_first.Add(keyframes[i].cloud, keyframes[i].T_world_camera).ok());
    }
  }
  ASSERT_TRUE(all.Remove(keyframes[0].cloud, keyframes[0].T_world_camera).ok());
  EXPECT_EQ(all.size(), without_first.size());
  ExpectSameCloud(all.Snapshot().points(), without_first.Snapshot().points(), kLeaf, 1e-7, 0);

  // A correction: the keyframe moved 5 cm comes out at its old pose, goes in at its new one.
  Eigen::Isometry3d moved = keyframes[1].T_world_camera;
  moved.translation().x() += 0.05;
  ASSERT_TRUE(all.Remove(keyframes[1].cloud, keyframes[1].T_world_camera).ok());
  ASSERT_TRUE(all.Add(keyframes[1].cloud, moved).ok());
  IncrementalCloud fresh = MakeCloud();
  for (size_t i = 1; i < keyframes.size(); ++i) {
    ASSERT_TRUE(fresh.Add(keyframes[i].cloud, i == 1 ? moved : keyframes[i].T_world_camera).ok());
  }
  ExpectSameCloud(all.Snapshot().points(), fresh.Snapshot().points(), kLeaf, 1e-7, 0);

  // Everything out: nothing left, not even an empty leaf.
  for (size_t i = 1; i < keyframes.size(); ++i) {
    ASSERT_TRUE(all.Remove(keyframes[i].cloud, i == 1 ? moved : keyframes[i].T_world_camera).ok());
  }
  EXPECT_EQ(all.size(), 0u);
  EXPECT_TRUE(all.Snapshot().empty());
}

TEST(IncrementalCloudTest, RemovingAtAnotherPoseIsRefused) {
  const Keyframe& k = RoomKeyframes()[0];
  IncrementalCloud cloud = MakeCloud();
  ASSERT_TRUE(cloud.Add(k.cloud, k.T_world_camera).ok());
  Eigen::Isometry3d elsewhere = k.T_world_camera;
  elsewhere.translation().z() += 1.0;
  EXPECT_EQ(cloud.Remove(k.cloud, elsewhere).code(), StatusCode::kFailedPrecondition);
  IncrementalCloud empty = MakeCloud();
  EXPECT_EQ(empty.Remove(k.cloud, k.T_world_camera).code(), StatusCode::kFailedPrecondition);
  cloud.Clear();
  EXPECT_EQ(cloud.size(), 0u);
}

TEST(IncrementalCloudTest, BadInputIsRefusedAndOddPointsAreLeftOut) {
  EXPECT_EQ(IncrementalCloud::Create({.leaf_size_m = 0}).status().code(),
            StatusCode::kInvalidArgument);
  IncrementalCloud cloud = MakeCloud();
  KeyframeCloud c;
  c.points = {{0.01f, 0.01f, 1.0f}, {std::numeric_limits<float>::quiet_NaN(), 0.0f, 1.0f}};
  c.colours = {{10, 20, 30}};
  EXPECT_EQ(cloud.Add(c, Eigen::Isometry3d::Identity()).code(), StatusCode::kInvalidArgument);
  c.colours.push_back({0, 0, 0});
  Eigen::Isometry3d bad = Eigen::Isometry3d::Identity();
  bad.translation().x() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(cloud.Add(c, bad).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(cloud.size(), 0u);

  // The NaN point is dropped; a point 100 km out does not fit a leaf key and is counted.
  c.points.emplace_back(1e5f, 0.0f, 0.0f);
  c.colours.push_back({0, 0, 0});
  ASSERT_TRUE(cloud.Add(c, Eigen::Isometry3d::Identity()).ok());
  EXPECT_EQ(cloud.size(), 1u);
  EXPECT_EQ(cloud.points_out_of_range(), 1u);
  const PointCloudMap snapshot = cloud.Snapshot();
  ASSERT_EQ(snapshot.size(), 1u);
  EXPECT_FLOAT_EQ(snapshot.points()[0].x, 0.01f);
  EXPECT_FLOAT_EQ(snapshot.points()[0].z, 1.0f);
  EXPECT_EQ(snapshot.points()[0].r, 30);  // BGR in, RGB out
  EXPECT_EQ(snapshot.points()[0].b, 10);
  ASSERT_TRUE(cloud.Remove(c, Eigen::Isometry3d::Identity()).ok());
  EXPECT_EQ(cloud.size(), 0u);
}

}  // namespace
}  // namespace semmap
