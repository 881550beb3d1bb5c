// OccupancyMap: known answers from the synthetic room (walls x = +-3, y = +-2.5, shelf front
// at x = -2.55), voxel colours, loop-closure rebuilds, .ot round trips (ColorOcTree and plain
// OcTree), .bt export and damaged bytes.
#include "core/mapping/occupancy_map.h"

#include <gtest/gtest.h>
#include <octomap/ColorOcTree.h>  // inner colours as OctoMap computes them
#include <octomap/OcTree.h>       // plain OcTree .ot input and .bt read-back

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "tests/testing/synth/default_scene.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/sequence_writer.h"
#include "tests/testing/synth/trajectory.h"

namespace semmap {
namespace {

const synth::Scene& Room() {
  static const synth::Scene* const scene = [] {
    StatusOr<synth::Scene> s = synth::MakeDefaultRoomScene(1);
    if (!s.ok()) std::abort();
    return new synth::Scene(std::move(s).value());
  }();
  return *scene;
}

const synth::Renderer& SharedRenderer() {
  static const synth::Renderer* const renderer = [] {
    StatusOr<synth::Renderer> r = synth::Renderer::Create(Room(), synth::DefaultSyntheticCamera());
    if (!r.ok()) std::abort();
    return new synth::Renderer(std::move(r).value());
  }();
  return *renderer;
}

// Every `every`-th pose of a 120-frame circle through the room (looking outwards).
std::vector<Eigen::Isometry3d> KeyframePoses(int every) {
  synth::TrajectoryOptions options;
  options.frames = 120;
  StatusOr<std::vector<StampedPose>> poses = synth::CircleTrajectory(Room().room, options);
  if (!poses.ok()) std::abort();
  std::vector<Eigen::Isometry3d> out;
  for (size_t i = 0; i < poses->size(); i += static_cast<size_t>(every)) {
    out.push_back((*poses)[i].T_world_camera);
  }
  return out;
}

struct Keyframe {
  synth::RenderedFrame frame;
  KeyframeCloud cloud;
  Eigen::Isometry3d T_world_camera;
};

std::vector<Keyframe> RenderKeyframes(const std::vector<Eigen::Isometry3d>& poses,
                                      const OccupancyMapOptions& options) {
  std::vector<Keyframe> out;
  for (const Eigen::Isometry3d& T : poses) {
    Keyframe k;
    k.frame = SharedRenderer().Render(T);
    StatusOr<KeyframeCloud> cloud = MakeKeyframeCloud(
        {k.frame.depth, synth::kDepthScale}, k.frame.bgr, SharedRenderer().camera(), options);
    EXPECT_TRUE(cloud.ok()) << cloud.status().ToString();
    if (cloud.ok()) k.cloud = std::move(cloud).value();
    k.T_world_camera = T;
    out.push_back(std::move(k));
  }
  return out;
}

std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> AtPoses(
    const std::vector<Keyframe>& keyframes, const Eigen::Isometry3d& T_offset) {
  std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> out;
  out.reserve(keyframes.size());
  for (const Keyframe& k : keyframes) out.emplace_back(&k.cloud, T_offset * k.T_world_camera);
  return out;
}

using VoxelKey = std::tuple<double, double, double, double, float>;
std::vector<VoxelKey> Keys(const OccupancyMap& map) {
  std::vector<VoxelKey> keys;
  for (const OccupancyMap::Voxel& v : map.OccupiedVoxels()) {
    keys.emplace_back(v.centre.x(), v.centre.y(), v.centre.z(), v.size, v.log_odds);
  }
  return keys;
}

using ColourKey = std::tuple<double, double, double, double, float, std::array<uint8_t, 3>>;
std::vector<ColourKey> ColourKeys(const OccupancyMap& map) {
  std::vector<ColourKey> keys;
  for (const OccupancyMap::Voxel& v : map.OccupiedVoxels()) {
    keys.emplace_back(v.centre.x(), v.centre.y(), v.centre.z(), v.size, v.log_odds, v.rgb);
  }
  return keys;
}

constexpr std::array<uint8_t, 3> kWhite = {255, 255, 255};

int MaxChannelDiff(const std::array<uint8_t, 3>& a, const std::array<uint8_t, 3>& b) {
  int d = 0;
  for (int i = 0; i < 3; ++i) d = std::max(d, std::abs(int{a[i]} - int{b[i]}));
  return d;
}

// Per leaf voxel (OctoMap's key: floor(coordinate / resolution) of the float world point, as
// OccupancyMap::Insert computes it): the sum of the RGB colours of the points in it.
struct VoxelColours {
  std::array<double, 3> sum{};
  int n = 0;
  std::array<uint8_t, 3> Mean() const {
    std::array<uint8_t, 3> m{};
    for (int i = 0; i < 3; ++i) m[i] = static_cast<uint8_t>(std::lround(sum[i] / n));
    return m;
  }
};
using VoxelIndex = std::array<int, 3>;
void AddPoints(const KeyframeCloud& cloud, const Eigen::Isometry3d& T, double resolution,
               std::map<VoxelIndex, VoxelColours>& voxels) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  const double factor = 1.0 / resolution;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f w = R * cloud.points[i] + t;
    const VoxelIndex index = {static_cast<int>(std::floor(factor * w.x())),
                              static_cast<int>(std::floor(factor * w.y())),
                              static_cast<int>(std::floor(factor * w.z()))};
    VoxelColours& v = voxels[index];
    for (int c = 0; c < 3; ++c) v.sum[c] += cloud.colours[i][2 - c];  // BGR -> RGB
    ++v.n;
  }
}
Eigen::Vector3d VoxelCentre(const VoxelIndex& index, double resolution) {
  return (Eigen::Vector3d(index[0], index[1], index[2]).array() + 0.5) * resolution;
}

// A surface point at a voxel boundary lands on either side: occupied on one of them.
bool OccupiedNear(const OccupancyMap& map, const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  const double h = 0.5 * map.resolution();
  return map.Occupancy(p) == VoxelState::kOccupied ||
         map.Occupancy(p + h * n) == VoxelState::kOccupied ||
         map.Occupancy(p - h * n) == VoxelState::kOccupied;
}

class OccupancyMapRoomTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    room_keyframes =
        new std::vector<Keyframe>(RenderKeyframes(KeyframePoses(10), OccupancyMapOptions{}));
    StatusOr<OccupancyMap> map =
        OccupancyMap::Build(AtPoses(*room_keyframes, Eigen::Isometry3d::Identity()), {});
    ASSERT_TRUE(map.ok()) << map.status().ToString();
    room_map = new OccupancyMap(std::move(map).value());
  }
  static void TearDownTestSuite() {
    delete room_map;
    delete room_keyframes;
  }

  static std::vector<Keyframe>* room_keyframes;
  static OccupancyMap* room_map;
};
std::vector<Keyframe>* OccupancyMapRoomTest::room_keyframes = nullptr;
OccupancyMap* OccupancyMapRoomTest::room_map = nullptr;

TEST(OccupancyMapOptionsTest, Validate) {
  EXPECT_TRUE(OccupancyMapOptions{}.Validate().ok());
  auto bad = [](auto edit) {
    OccupancyMapOptions o;
    edit(o);
    return o.Validate().code() == StatusCode::kInvalidArgument;
  };
  EXPECT_TRUE(bad([](OccupancyMapOptions& o) { o.resolution_m = 0; }));
  EXPECT_TRUE(bad([](OccupancyMapOptions& o) { o.resolution_m = std::nan(""); }));
  EXPECT_TRUE(bad([](OccupancyMapOptions& o) { o.resolution_m = 2; }));
  EXPECT_TRUE(bad([](OccupancyMapOptions& o) { o.max_range_m = -1; }));
  EXPECT_TRUE(bad([](OccupancyMapOptions& o) { o.max_range_m = INFINITY; }));
  EXPECT_TRUE(bad([](OccupancyMapOptions& o) { o.pixel_step = 0; }));
  EXPECT_TRUE(bad([](OccupancyMapOptions& o) { o.pixel_step = 65; }));
  OccupancyMapOptions o;
  o.resolution_m = -1;
  EXPECT_EQ(OccupancyMap::Create(o).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(OccupancyMap::Build({}, o).status().code(), StatusCode::kInvalidArgument);
}

// What a map keeps per keyframe (semmapd's --map-keyframe-voxel): one mean point and colour per
// cube in the keyframe's frame, far fewer points where the surface is near.
TEST(KeyframeCloudTest, KeyframeVoxelKeepsOneMeanPointPerCube) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  cv::Mat depth(camera.height, camera.width, CV_16UC1, cv::Scalar(5000));  // 1 m
  cv::Mat bgr(camera.height, camera.width, CV_8UC3, cv::Scalar(10, 20, 30));
  bgr(cv::Rect(0, 0, camera.width / 2, camera.height)).setTo(cv::Scalar(20, 40, 60));
  OccupancyMapOptions options;
  StatusOr<KeyframeCloud> every = MakeKeyframeCloud({depth, 5000.0}, bgr, camera, options);
  options.keyframe_voxel_m = 0.02;
  StatusOr<KeyframeCloud> voxels = MakeKeyframeCloud({depth, 5000.0}, bgr, camera, options);
  ASSERT_TRUE(every.ok() && voxels.ok());
  // At 1 m the 4-pixel grid is about 8 mm: 4 to 9 points per 2 cm cube.
  EXPECT_LT(voxels->size() * 3, every->size());
  EXPECT_GT(voxels->size() * 12, every->size());
  ASSERT_EQ(voxels->colours.size(), voxels->size());
  for (size_t i = 0; i < voxels->size(); ++i) {
    const Eigen::Vector3f& p = voxels->points[i];
    EXPECT_FLOAT_EQ(p.z(), 1.0F);
    // The mean of points in one cube lies in that cube.
    EXPECT_LT(std::abs(p.x() - (std::floor(p.x() / 0.02F) + 0.5F) * 0.02F), 0.0101F);
    const std::array<uint8_t, 3>& c = voxels->colours[i];
    EXPECT_TRUE(c[0] >= 10 && c[0] <= 20 && c[1] >= 20 && c[1] <= 40) << int{c[0]};
  }
  options.keyframe_voxel_m = 0.5;  // coarser than the occupancy resolution
  EXPECT_EQ(options.Validate().code(), StatusCode::kInvalidArgument);
  options.keyframe_voxel_m = 0.0005;
  EXPECT_EQ(options.Validate().code(), StatusCode::kInvalidArgument);
  options.keyframe_voxel_m = 0;
  EXPECT_TRUE(options.Validate().ok());
}

TEST(KeyframeCloudTest, SubsamplesBackProjectsAndDropsFarPoints) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  cv::Mat depth(camera.height, camera.width, CV_16UC1, cv::Scalar(10000));  // 2 m
  depth(cv::Rect(0, 0, camera.width, 100)).setTo(0);                        // no depth
  depth(cv::Rect(0, 100, camera.width, 100)).setTo(30000);                  // 6 m: too far
  const cv::Mat bgr(camera.height, camera.width, CV_8UC3, cv::Scalar(1, 2, 3));
  OccupancyMapOptions options;
  StatusOr<KeyframeCloud> cloud = MakeKeyframeCloud({depth, 5000.0}, bgr, camera, options);
  ASSERT_TRUE(cloud.ok()) << cloud.status().ToString();
  // Rows 2, 6, ... from 200 on, columns 2, 6, ..., 638.
  EXPECT_EQ(cloud->size(), static_cast<size_t>((480 - 200) / 4 * (640 / 4)));
  ASSERT_EQ(cloud->colours.size(), cloud->size());
  for (size_t i = 0; i < cloud->size(); ++i) {
    EXPECT_FLOAT_EQ(cloud->points[i].z(), 2.0F);
    EXPECT_EQ(cloud->colours[i], (std::array<uint8_t, 3>{1, 2, 3}));
  }
  // The first point: pixel (2, 202).
  EXPECT_NEAR(cloud->points[0].x(), (2 - camera.cx) / camera.fx * 2.0, 1e-5);
  EXPECT_NEAR(cloud->points[0].y(), (202 - camera.cy) / camera.fy * 2.0, 1e-5);

  options.pixel_step = 1;
  EXPECT_EQ(MakeKeyframeCloud({depth, 5000.0}, bgr, camera, options)->size(), 280U * 640U);

  EXPECT_FALSE(MakeKeyframeCloud({depth, 0.0}, bgr, camera, {}).ok());
  EXPECT_FALSE(MakeKeyframeCloud({cv::Mat(), 5000.0}, bgr, camera, {}).ok());
  cv::Mat float_depth;
  depth.convertTo(float_depth, CV_32F);
  EXPECT_FALSE(MakeKeyframeCloud({float_depth, 5000.0}, bgr, camera, {}).ok());
  EXPECT_FALSE(MakeKeyframeCloud({depth, 5000.0}, bgr(cv::Rect(0, 0, 320, 240)), camera, {}).ok());
  EXPECT_FALSE(
      MakeKeyframeCloud({depth, 5000.0}, bgr, synth::DefaultSyntheticCamera(320, 240), {}).ok());
  EXPECT_FALSE(MakeKeyframeCloud({depth, 5000.0}, cv::Mat(480, 640, CV_32FC3), camera, {}).ok());
}

TEST_F(OccupancyMapRoomTest, WallsAndShelfAreOccupied) {
  const OccupancyMap& map = *room_map;
  // Wall points away from the furniture, at the camera height.
  EXPECT_TRUE(OccupiedNear(map, {3.0, 0.8, 1.4}, Eigen::Vector3d::UnitX()));
  EXPECT_TRUE(OccupiedNear(map, {-3.0, -1.5, 1.4}, Eigen::Vector3d::UnitX()));
  EXPECT_TRUE(OccupiedNear(map, {-1.5, 2.5, 1.4}, Eigen::Vector3d::UnitY()));
  EXPECT_TRUE(OccupiedNear(map, {1.5, -2.5, 1.4}, Eigen::Vector3d::UnitY()));
  // The shelf's front face (box at x = -2.77, 0.44 deep, y in [0.2, 1.4], 1.8 high).
  EXPECT_TRUE(OccupiedNear(map, {-2.55, 0.8, 1.3}, Eigen::Vector3d::UnitX()));
  // Every rendered depth pixel on a coarse grid ends in an occupied voxel.
  const CameraCalibration& c = SharedRenderer().camera();
  int checked = 0, hit = 0;
  for (const Keyframe& k : *room_keyframes) {
    for (int v = 20; v < c.height; v += 40) {
      for (int u = 20; u < c.width; u += 40) {
        const double z = k.frame.depth.at<uint16_t>(v, u) / synth::kDepthScale;
        const Eigen::Vector3d ray((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0);
        if (z <= 0 || z * ray.norm() > 3.9) continue;
        const Eigen::Vector3d p = k.T_world_camera * (z * ray);
        const Eigen::Vector3d dir = k.T_world_camera.linear() * ray.normalized();
        ++checked;
        hit += OccupiedNear(map, p, dir) ? 1 : 0;
      }
    }
  }
  ASSERT_GT(checked, 500);
  EXPECT_GE(hit, checked * 98 / 100) << hit << " of " << checked;
}

TEST_F(OccupancyMapRoomTest, FreeBetweenCameraAndWallUnknownBehind) {
  const OccupancyMap& map = *room_map;
  const CameraCalibration& c = SharedRenderer().camera();
  int checked = 0, free = 0;
  for (const Keyframe& k : *room_keyframes) {
    for (int v = 60; v < c.height; v += 60) {
      for (int u = 60; u < c.width; u += 60) {
        const double z = k.frame.depth.at<uint16_t>(v, u) / synth::kDepthScale;
        const Eigen::Vector3d ray((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0);
        if (z <= 0.5 || z * ray.norm() > 3.9) continue;
        for (double f : {0.3, 0.5, 0.7}) {
          ++checked;
          free += map.Occupancy(k.T_world_camera * (f * z * ray)) == VoxelState::kFree ? 1 : 0;
        }
      }
    }
  }
  ASSERT_GT(checked, 300);
  EXPECT_GE(free, checked * 98 / 100) << free << " of " << checked;
  // Behind the walls, above the ceiling, below the floor, and outside the tree's range.
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(4.0, 0.0, 1.4), Eigen::Vector3d(-4.0, -1.0, 1.4),
        Eigen::Vector3d(0.0, 3.5, 1.4), Eigen::Vector3d(1.0, -3.5, 1.4),
        Eigen::Vector3d(0.0, 0.0, 3.6), Eigen::Vector3d(0.5, 0.5, -0.8),
        Eigen::Vector3d(1e6, 0.0, 0.0), Eigen::Vector3d(NAN, 0.0, 0.0)}) {
    EXPECT_EQ(map.Occupancy(p), VoxelState::kUnknown) << p.transpose();
  }
  // Known space stays inside the room grown by a voxel or two.
  const Eigen::AlignedBox3d bounds = map.Bounds();
  ASSERT_FALSE(bounds.isEmpty());
  EXPECT_TRUE(Room().room.sizes().x() > 0);
  Eigen::AlignedBox3d grown = Room().room;
  grown.min().array() -= 0.11;
  grown.max().array() += 0.11;
  EXPECT_TRUE(grown.contains(bounds))
      << bounds.min().transpose() << " / " << bounds.max().transpose();
  EXPECT_GT(bounds.sizes().x(), 5.5);
  EXPECT_GT(bounds.sizes().y(), 4.5);
}

TEST_F(OccupancyMapRoomTest, RebuildAfterLoopClosureMatchesFreshBuild) {
  // The drifted map: every keyframe off by the same rigid offset.
  const Eigen::Isometry3d T_drift =
      Eigen::Translation3d(0.3, -0.2, 0.1) * Eigen::AngleAxisd(0.08, Eigen::Vector3d::UnitZ());
  StatusOr<OccupancyMap> drifted = OccupancyMap::Build(AtPoses(*room_keyframes, T_drift), {});
  ASSERT_TRUE(drifted.ok()) << drifted.status().ToString();
  EXPECT_NE(Keys(*drifted), Keys(*room_map));
  EXPECT_FALSE(OccupiedNear(*drifted, {3.0, 0.8, 1.4}, Eigen::Vector3d::UnitX()));
  // Corrected poses: rebuilt from the same keyframe-frame clouds.
  StatusOr<OccupancyMap> rebuilt =
      OccupancyMap::Build(AtPoses(*room_keyframes, Eigen::Isometry3d::Identity()), {});
  ASSERT_TRUE(rebuilt.ok());
  // A fresh build from newly rendered keyframes at the true poses.
  const std::vector<Keyframe> fresh_keyframes = RenderKeyframes(KeyframePoses(10), {});
  StatusOr<OccupancyMap> fresh =
      OccupancyMap::Build(AtPoses(fresh_keyframes, Eigen::Isometry3d::Identity()), {});
  ASSERT_TRUE(fresh.ok());
  EXPECT_EQ(rebuilt->size(), fresh->size());
  EXPECT_EQ(Keys(*rebuilt), Keys(*fresh));
  EXPECT_TRUE(OccupiedNear(*rebuilt, {3.0, 0.8, 1.4}, Eigen::Vector3d::UnitX()));
}

TEST_F(OccupancyMapRoomTest, OtRoundTripPreservesTreeAndLeavesLiveTreeAlone) {
  const size_t size_before = room_map->size();
  const std::vector<VoxelKey> keys_before = Keys(*room_map);
  ASSERT_GT(keys_before.size(), 1000U);
  StatusOr<std::string> ot = room_map->SerializeOt();
  ASSERT_TRUE(ot.ok()) << ot.status().ToString();
  StatusOr<std::string> bt = room_map->SerializeBt();
  ASSERT_TRUE(bt.ok()) << bt.status().ToString();
  EXPECT_EQ(bt->rfind("# Octomap OcTree binary file", 0), 0U);
  EXPECT_LT(bt->size(), ot->size());
  EXPECT_EQ(room_map->size(), size_before);
  EXPECT_EQ(Keys(*room_map), keys_before);

  OccupancyMapOptions options;
  options.resolution_m = 0.1;  // overridden by the file's
  StatusOr<OccupancyMap> back = OccupancyMap::DeserializeOt(*ot, options);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_DOUBLE_EQ(back->resolution(), 0.05);
  EXPECT_EQ(back->size(), size_before);
  EXPECT_EQ(Keys(*back), keys_before);  // centres, sizes and log-odds
  EXPECT_EQ(*back->SerializeOt(), *ot);
  // Insertion still works on a loaded map.
  EXPECT_TRUE(back->Insert((*room_keyframes)[0].cloud, (*room_keyframes)[0].T_world_camera).ok());
}

TEST_F(OccupancyMapRoomTest, OtRoundTripPreservesColoursExactly) {
  const std::vector<ColourKey> before = ColourKeys(*room_map);
  ASSERT_GT(before.size(), 1000U);
  // Colour made it into the tree: almost every occupied voxel has one.
  const auto coloured = std::count_if(before.begin(), before.end(),
                                      [](const ColourKey& k) { return std::get<5>(k) != kWhite; });
  EXPECT_GT(coloured, static_cast<std::ptrdiff_t>(before.size() * 99 / 100));
  StatusOr<std::string> ot = room_map->SerializeOt();
  ASSERT_TRUE(ot.ok()) << ot.status().ToString();
  EXPECT_NE(ot->find("\nid ColorOcTree\n"), std::string::npos);
  StatusOr<OccupancyMap> back = OccupancyMap::DeserializeOt(*ot);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(ColourKeys(*back), before);
  EXPECT_EQ(ColourKeys(*room_map), before);  // serialising left the live tree alone
  for (const OccupancyMap::Voxel& v : back->OccupiedVoxels()) {
    ASSERT_EQ(back->ColourAt(v.centre), v.rgb);
    ASSERT_EQ(room_map->ColourAt(v.centre), v.rgb);
  }
}

// Insert() updates inner colours only above the voxels it recoloured; OctoMap's full
// ColorOcTree::updateInnerOccupancy() on the saved tree gives the same inner nodes.
TEST_F(OccupancyMapRoomTest, InnerColoursMatchOctomapsFullUpdate) {
  StatusOr<std::string> ot = room_map->SerializeOt();
  ASSERT_TRUE(ot.ok());
  std::istringstream in(*ot);
  std::unique_ptr<octomap::AbstractOcTree> read(octomap::AbstractOcTree::read(in));
  auto* tree = dynamic_cast<octomap::ColorOcTree*>(read.get());
  ASSERT_NE(tree, nullptr);
  std::istringstream in_again(*ot);
  std::unique_ptr<octomap::AbstractOcTree> read_again(octomap::AbstractOcTree::read(in_again));
  auto* full = dynamic_cast<octomap::ColorOcTree*>(read_again.get());
  ASSERT_NE(full, nullptr);
  full->updateInnerOccupancy();
  size_t inner = 0, differ = 0;
  for (auto a = tree->begin_tree(), b = full->begin_tree(), end = tree->end_tree(); a != end;
       ++a, ++b) {
    ASSERT_EQ(a.getKey(), b.getKey());
    ASSERT_EQ(a.getDepth(), b.getDepth());
    ASSERT_EQ(a->getValue(), b->getValue());  // occupancy was current already
    if (a.isLeaf()) {
      ASSERT_EQ(a->getColor(), b->getColor());
      continue;
    }
    ++inner;
    differ += a->getColor() != b->getColor() ? 1 : 0;
  }
  ASSERT_GT(inner, 10000U);
  // Equal here; pruning free space may leave an occasional parent with its earlier mean.
  EXPECT_LE(differ, inner / 1000) << differ << " of " << inner << " inner nodes";
}

TEST_F(OccupancyMapRoomTest, BtReadsBackAsPlainOcTree) {
  StatusOr<std::string> bt = room_map->SerializeBt();
  ASSERT_TRUE(bt.ok()) << bt.status().ToString();
  EXPECT_NE(bt->find("\nid OcTree\n"), std::string::npos);
  octomap::OcTree tree(0.1);
  std::istringstream in(*bt);
  ASSERT_TRUE(tree.readBinary(in));
  EXPECT_DOUBLE_EQ(tree.getResolution(), 0.05);
  ASSERT_GT(tree.size(), 0U);
  EXPECT_LT(tree.size(), room_map->size());  // pruned
  // Max-likelihood: the same occupied / free split as the live map.
  const std::vector<OccupancyMap::Voxel> occupied = room_map->OccupiedVoxels();
  for (const OccupancyMap::Voxel& v : occupied) {
    const octomap::OcTreeNode* node = tree.search(v.centre.x(), v.centre.y(), v.centre.z());
    ASSERT_NE(node, nullptr) << v.centre.transpose();
    ASSERT_TRUE(tree.isNodeOccupied(node)) << v.centre.transpose();
  }
  size_t bt_occupied = 0;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const octomap::point3d c = it.getCoordinate();
    EXPECT_EQ(room_map->Occupancy({c.x(), c.y(), c.z()}), VoxelState::kOccupied);
    ++bt_occupied;
  }
  EXPECT_GT(bt_occupied, 0U);
  EXPECT_LE(bt_occupied, occupied.size());  // pruning can merge occupied leaves
  // Half way along the ray through the first keyframe's centre pixel.
  const Keyframe& k = (*room_keyframes)[0];
  const CameraCalibration& c = SharedRenderer().camera();
  const int u = c.width / 2, v = c.height / 2;
  const double z = k.frame.depth.at<uint16_t>(v, u) / synth::kDepthScale;
  ASSERT_GT(z, 1.0);
  const Eigen::Vector3d free_point =
      k.T_world_camera * (0.5 * z * Eigen::Vector3d((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0));
  ASSERT_EQ(room_map->Occupancy(free_point), VoxelState::kFree);
  const octomap::OcTreeNode* node = tree.search(free_point.x(), free_point.y(), free_point.z());
  ASSERT_NE(node, nullptr);
  EXPECT_FALSE(tree.isNodeOccupied(node));
}

// One keyframe facing the +x wall (x = 3) from 2.5 m: every wall voxel's colour is the mean
// colour of the keyframe's points in it; seeing the same frame again keeps it.
TEST(OccupancyMapColourTest, WallVoxelsGetTheMeanColourOfTheirPixels) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = -Eigen::Vector3d::UnitY();  // image right
  T.linear().col(1) = -Eigen::Vector3d::UnitZ();  // image down
  T.linear().col(2) = Eigen::Vector3d::UnitX();   // forward
  T.translation() = Eigen::Vector3d(0.5, 1.0, 1.7);
  const std::vector<Keyframe> keyframes = RenderKeyframes({T}, {});
  ASSERT_EQ(keyframes.size(), 1U);
  const KeyframeCloud& cloud = keyframes[0].cloud;
  ASSERT_GT(cloud.size(), 10000U);
  StatusOr<OccupancyMap> map = OccupancyMap::Create({});
  ASSERT_TRUE(map.ok());
  ASSERT_TRUE(map->Insert(cloud, T).ok());

  std::map<VoxelIndex, VoxelColours> voxels;
  AddPoints(cloud, T, map->resolution(), voxels);
  // Returns how many wall voxels have exactly the rounded mean.
  auto check_wall = [&](const char* when) {
    int wall = 0, uncoloured = 0, exact = 0, close = 0, grey_ish = 0;
    for (const auto& [index, colours] : voxels) {
      const Eigen::Vector3d centre = VoxelCentre(index, map->resolution());
      if (std::abs(centre.x() - 3.0) > 0.1 || centre.z() < 0.9 || centre.z() > 2.6) continue;
      ++wall;
      const std::optional<std::array<uint8_t, 3>> rgb = map->ColourAt(centre);
      if (!rgb.has_value()) {
        ++uncoloured;
        continue;
      }
      const std::array<uint8_t, 3> mean = colours.Mean();
      const int diff = MaxChannelDiff(*rgb, mean);
      exact += diff == 0 ? 1 : 0;
      close += diff <= 1 ? 1 : 0;  // OctoMap's (old + new) / 2 truncates
      grey_ish += MaxChannelDiff(mean, {mean[0], mean[0], mean[0]}) <= 3 ? 1 : 0;
    }
    EXPECT_GT(wall, 300) << when;
    EXPECT_EQ(uncoloured, 0) << when << ": wall voxels not occupied";
    EXPECT_GE(close, wall * 99 / 100) << when << ": " << close << " of " << wall;
    EXPECT_LT(grey_ish, wall / 2) << "the wall has a hue: a channel mix-up would show";
    return exact;
  };
  EXPECT_GT(check_wall("after one insertion"), 0);
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(map->Insert(cloud, T).ok());
  check_wall("after four insertions");

  // A second view from nearby, into a fresh map after the first: voxels both views saw get
  // OctoMap's average (first + second) / 2, the others their one view's mean.
  Eigen::Isometry3d T2 = T;
  T2.translation() += Eigen::Vector3d(0.2, -0.15, -0.1);
  const std::vector<Keyframe> second = RenderKeyframes({T2}, {});
  ASSERT_EQ(second.size(), 1U);
  StatusOr<OccupancyMap> both = OccupancyMap::Create({});
  ASSERT_TRUE(both.ok());
  ASSERT_TRUE(both->Insert(cloud, T).ok());
  ASSERT_TRUE(both->Insert(second[0].cloud, T2).ok());
  std::map<VoxelIndex, VoxelColours> voxels2;
  AddPoints(second[0].cloud, T2, both->resolution(), voxels2);
  int wall = 0, seen_twice = 0, close = 0;
  for (const auto& [index, colours2] : voxels2) {
    const Eigen::Vector3d centre = VoxelCentre(index, both->resolution());
    if (std::abs(centre.x() - 3.0) > 0.1 || centre.z() < 0.9 || centre.z() > 2.6) continue;
    ++wall;
    std::array<uint8_t, 3> expected = colours2.Mean();
    if (const auto first = voxels.find(index); first != voxels.end()) {
      ++seen_twice;
      const std::array<uint8_t, 3> m1 = first->second.Mean();
      for (int c = 0; c < 3; ++c) expected[c] = static_cast<uint8_t>((m1[c] + expected[c]) / 2);
    }
    const std::optional<std::array<uint8_t, 3>> rgb = both->ColourAt(centre);
    close += rgb.has_value() && MaxChannelDiff(*rgb, expected) <= 1 ? 1 : 0;
  }
  EXPECT_GT(seen_twice, 300);
  EXPECT_GE(close, wall * 99 / 100) << close << " of " << wall;
}

TEST(OccupancyMapColourTest, KeyframeMeanThenAveragedAcrossKeyframes) {
  StatusOr<OccupancyMap> map = OccupancyMap::Create({});
  ASSERT_TRUE(map.ok());
  // Two points in the voxel [0, 0.05) x [0, 0.05) x [1, 1.05), BGR colours.
  KeyframeCloud cloud;
  cloud.points = {{0.01F, 0.01F, 1.01F}, {0.03F, 0.04F, 1.02F}};
  cloud.colours = {{10, 20, 30}, {30, 40, 51}};
  ASSERT_TRUE(map->Insert(cloud, Eigen::Isometry3d::Identity()).ok());
  const Eigen::Vector3d p(0.02, 0.02, 1.02);
  // The keyframe's mean in RGB, rounded: (40.5, 30, 20).
  EXPECT_EQ(map->ColourAt(p), (std::array<uint8_t, 3>{41, 30, 20}));
  ASSERT_EQ(map->OccupiedVoxels().size(), 1U);
  EXPECT_EQ(map->OccupiedVoxels()[0].rgb, (std::array<uint8_t, 3>{41, 30, 20}));
  // A second keyframe sees it black: averaged with the previous colour.
  cloud.colours = {{0, 0, 0}, {0, 0, 0}};
  ASSERT_TRUE(map->Insert(cloud, Eigen::Isometry3d::Identity()).ok());
  EXPECT_EQ(map->ColourAt(p), (std::array<uint8_t, 3>{20, 15, 10}));
  // Free, unknown and invalid points have no colour.
  EXPECT_EQ(map->Occupancy({0.02, 0.02, 0.5}), VoxelState::kFree);
  EXPECT_EQ(map->ColourAt({0.02, 0.02, 0.5}), std::nullopt);
  EXPECT_EQ(map->ColourAt({1.0, 1.0, 1.0}), std::nullopt);
  EXPECT_EQ(map->ColourAt({NAN, 0.0, 1.0}), std::nullopt);
  EXPECT_EQ(map->ColourAt({1e6, 0.0, 1.0}), std::nullopt);
  // Colours must match the points one to one.
  cloud.colours.pop_back();
  EXPECT_EQ(map->Insert(cloud, Eigen::Isometry3d::Identity()).code(), StatusCode::kInvalidArgument);
  // An empty cloud into an empty map (no root yet) is fine.
  StatusOr<OccupancyMap> empty = OccupancyMap::Create({});
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->Insert(KeyframeCloud{}, Eigen::Isometry3d::Identity()).ok());
  EXPECT_EQ(empty->size(), 0U);
  EXPECT_TRUE(empty->SerializeBt().ok());
}

// A plain OcTree .ot (as older maps and other tools write) loads with the same occupancy as a
// map built from the same keyframe, uncoloured; damaged ones are still errors.
TEST(OccupancyMapTest, PlainOcTreeOtLoadsUncoloured) {
  const std::vector<Keyframe> keyframes = RenderKeyframes(KeyframePoses(60), {});
  ASSERT_EQ(keyframes.size(), 2U);
  const OccupancyMapOptions options;
  octomap::OcTree plain(options.resolution_m);
  for (const Keyframe& k : keyframes) {
    octomap::Pointcloud scan;
    const Eigen::Matrix3f R = k.T_world_camera.linear().cast<float>();
    const Eigen::Vector3f t = k.T_world_camera.translation().cast<float>();
    for (const Eigen::Vector3f& p : k.cloud.points) {
      if (p.squaredNorm() > options.max_range_m * options.max_range_m) continue;  // as Insert
      const Eigen::Vector3f w = R * p + t;
      scan.push_back(w.x(), w.y(), w.z());
    }
    plain.insertPointCloud(scan, octomap::point3d(t.x(), t.y(), t.z()), options.max_range_m,
                           /*lazy_eval=*/false, options.discretize);
  }
  std::ostringstream out;
  ASSERT_TRUE(plain.write(out));
  const std::string ot = out.str();
  ASSERT_NE(ot.find("\nid OcTree\n"), std::string::npos);

  StatusOr<OccupancyMap> loaded = OccupancyMap::DeserializeOt(ot);
  ASSERT_TRUE(loaded.ok()) << loaded.status().ToString();
  StatusOr<OccupancyMap> built =
      OccupancyMap::Build(AtPoses(keyframes, Eigen::Isometry3d::Identity()), options);
  ASSERT_TRUE(built.ok());
  EXPECT_EQ(loaded->size(), plain.size());
  EXPECT_EQ(loaded->size(), built->size());
  EXPECT_EQ(Keys(*loaded), Keys(*built));  // centres, sizes and log-odds
  const std::vector<OccupancyMap::Voxel> voxels = loaded->OccupiedVoxels();
  ASSERT_GT(voxels.size(), 1000U);
  for (const OccupancyMap::Voxel& v : voxels) {
    ASSERT_EQ(v.rgb, kWhite);
    ASSERT_EQ(loaded->ColourAt(v.centre), kWhite);
  }
  // It saves as a ColorOcTree, round trips, and takes colour from new keyframes.
  StatusOr<std::string> colour_ot = loaded->SerializeOt();
  ASSERT_TRUE(colour_ot.ok());
  EXPECT_NE(colour_ot->find("\nid ColorOcTree\n"), std::string::npos);
  StatusOr<OccupancyMap> again = OccupancyMap::DeserializeOt(*colour_ot);
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  EXPECT_EQ(ColourKeys(*again), ColourKeys(*loaded));
  ASSERT_TRUE(again->Insert(keyframes[0].cloud, keyframes[0].T_world_camera).ok());
  const std::vector<OccupancyMap::Voxel> recoloured = again->OccupiedVoxels();
  EXPECT_GT(std::count_if(recoloured.begin(), recoloured.end(),
                          [](const OccupancyMap::Voxel& v) { return v.rgb != kWhite; }),
            static_cast<std::ptrdiff_t>(recoloured.size() / 2));

  // Damaged plain .ot bytes: truncated anywhere, or the root's child bits flipped.
  const size_t data = ot.find("\ndata\n") + 6;
  for (size_t n = data; n < ot.size(); n += 101) {
    EXPECT_EQ(OccupancyMap::DeserializeOt(std::string_view(ot).substr(0, n)).status().code(),
              StatusCode::kDataLoss)
        << n;
  }
  for (int bit = 0; bit < 8; ++bit) {
    std::string bad = ot;
    bad[data + 4] = static_cast<char>(bad[data + 4] ^ (1 << bit));
    EXPECT_EQ(OccupancyMap::DeserializeOt(bad).status().code(), StatusCode::kDataLoss) << bit;
  }
}

TEST(OccupancyMapTest, EmptyMapRoundTrips) {
  StatusOr<OccupancyMap> map = OccupancyMap::Create({});
  ASSERT_TRUE(map.ok());
  EXPECT_EQ(map->size(), 0U);
  EXPECT_TRUE(map->Bounds().isEmpty());
  EXPECT_EQ(map->Occupancy(Eigen::Vector3d::Zero()), VoxelState::kUnknown);
  StatusOr<std::string> ot = map->SerializeOt();
  ASSERT_TRUE(ot.ok());
  StatusOr<OccupancyMap> back = OccupancyMap::DeserializeOt(*ot);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->size(), 0U);
  EXPECT_EQ(OccupancyMap::DeserializeOt(*ot + "x").status().code(), StatusCode::kDataLoss);
}

// Build() casts the next keyframes' rays on a second thread: the tree must be the one inserting
// them one after another gives, byte for byte (occupancy, colours, structure).
TEST_F(OccupancyMapRoomTest, BuildEqualsInsertingOneAfterAnother) {
  StatusOr<OccupancyMap> sequential = OccupancyMap::Create({});
  ASSERT_TRUE(sequential.ok());
  for (const auto& [cloud, T] : AtPoses(*room_keyframes, Eigen::Isometry3d::Identity())) {
    ASSERT_TRUE(sequential->Insert(*cloud, T).ok());
  }
  EXPECT_EQ(*sequential->SerializeOt(), *room_map->SerializeOt());
}

TEST_F(OccupancyMapRoomTest, BuildStopsAtAFailingKeyframeOrACancel) {
  auto keyframes = AtPoses(*room_keyframes, Eigen::Isometry3d::Identity());
  ASSERT_GT(keyframes.size(), 6u);
  keyframes[5].second = Eigen::Isometry3d(Eigen::Translation3d(5000, 0, 0));
  const Status failed = OccupancyMap::Build(keyframes, {}).status();
  EXPECT_EQ(failed.code(), StatusCode::kOutOfRange) << failed.ToString();
  EXPECT_NE(failed.message().find("keyframe 5"), std::string::npos) << failed.ToString();

  int asked = 0;
  const CancelCheck cancel = [&]() -> Status {
    return ++asked > 3 ? CancelledError("rebuild superseded") : OkStatus();
  };
  const Status cancelled =
      OccupancyMap::Build(AtPoses(*room_keyframes, Eigen::Isometry3d::Identity()), {}, cancel)
          .status();
  EXPECT_EQ(cancelled.code(), StatusCode::kCancelled) << cancelled.ToString();
  EXPECT_EQ(asked, 4);
}

TEST_F(OccupancyMapRoomTest, BuildFromASourceReadsKeyframesInOrderAndMakesTheSameTree) {
  const auto keyframes = AtPoses(*room_keyframes, Eigen::Isometry3d::Identity());
  StatusOr<OccupancyMap> from_vector = OccupancyMap::Build(keyframes, {});
  ASSERT_TRUE(from_vector.ok());
  // Each cloud a copy made when asked for (as the layers read evicted ones back).
  std::atomic<size_t> asked{0};
  std::vector<size_t> inserted;
  const auto source = [&](size_t i)
      -> StatusOr<std::pair<std::shared_ptr<const KeyframeCloud>, Eigen::Isometry3d>> {
    EXPECT_EQ(i, asked.fetch_add(1));
    return std::make_pair(std::make_shared<const KeyframeCloud>(*keyframes[i].first),
                          keyframes[i].second);
  };
  StatusOr<OccupancyMap> from_source =
      OccupancyMap::Build(keyframes.size(), source, {}, {},
                          [&](size_t i, const std::shared_ptr<const KeyframeCloud>& cloud) {
                            EXPECT_EQ(cloud->points, keyframes[i].first->points);
                            inserted.push_back(i);
                          });
  ASSERT_TRUE(from_source.ok()) << from_source.status().ToString();
  EXPECT_EQ(*from_source->SerializeOt(), *from_vector->SerializeOt());
  EXPECT_EQ(asked.load(), keyframes.size());
  ASSERT_EQ(inserted.size(), keyframes.size());
  for (size_t i = 0; i < inserted.size(); ++i) EXPECT_EQ(inserted[i], i);

  // The source's error ends the build, named by keyframe; a null cloud is refused.
  const auto failing = [&](size_t i)
      -> StatusOr<std::pair<std::shared_ptr<const KeyframeCloud>, Eigen::Isometry3d>> {
    if (i == 2) return DataLossError("stored depth damaged");
    return std::make_pair(std::shared_ptr<const KeyframeCloud>(), keyframes[i].second);
  };
  const Status failed = OccupancyMap::Build(keyframes.size(), failing, {}).status();
  EXPECT_EQ(failed.code(), StatusCode::kInvalidArgument) << failed.ToString();
  EXPECT_NE(failed.message().find("keyframe 0"), std::string::npos) << failed.ToString();
  const auto damaged = [&](size_t i)
      -> StatusOr<std::pair<std::shared_ptr<const KeyframeCloud>, Eigen::Isometry3d>> {
    if (i == 2) return DataLossError("stored depth damaged");
    return std::make_pair(std::make_shared<const KeyframeCloud>(*keyframes[i].first),
                          keyframes[i].second);
  };
  const Status lost = OccupancyMap::Build(keyframes.size(), damaged, {}).status();
  EXPECT_EQ(lost.code(), StatusCode::kDataLoss) << lost.ToString();
  EXPECT_NE(lost.message().find("keyframe 2"), std::string::npos) << lost.ToString();
}

TEST(OccupancyMapTest, BadInputsAreErrors) {
  StatusOr<OccupancyMap> map = OccupancyMap::Create({});
  ASSERT_TRUE(map.ok());
  KeyframeCloud cloud;
  cloud.points.emplace_back(0, 0, 1);
  cloud.colours.push_back({0, 0, 0});
  Eigen::Isometry3d nan_pose = Eigen::Isometry3d::Identity();
  nan_pose.translation().x() = NAN;
  EXPECT_EQ(map->Insert(cloud, nan_pose).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(map->Insert(cloud, Eigen::Isometry3d(Eigen::Translation3d(5000, 0, 0))).code(),
            StatusCode::kOutOfRange);
  EXPECT_EQ(OccupancyMap::Build({{nullptr, Eigen::Isometry3d::Identity()}}, {}).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_TRUE(map->Insert(cloud, Eigen::Isometry3d::Identity()).ok());
  EXPECT_EQ(map->Occupancy({0.01, 0.01, 1.0}), VoxelState::kOccupied);
  EXPECT_EQ(map->Occupancy({0.01, 0.01, 0.5}), VoxelState::kFree);
}

// Found by fuzz_occupancy_ot (UBSan): a finite point beyond the int range went to OctoMap's
// coordToKeyChecked, which converts the scaled coordinate to int before its range check.
TEST(OccupancyMapTest, QueriesFarOutsideTheTreeAreUnknown) {
  StatusOr<OccupancyMap> map = OccupancyMap::Create({});
  ASSERT_TRUE(map.ok());
  KeyframeCloud cloud;
  cloud.points.emplace_back(0, 0, 1);
  cloud.colours.push_back({0, 0, 0});
  ASSERT_TRUE(map->Insert(cloud, Eigen::Isometry3d::Identity()).ok());
  const double edge = map->resolution() * 32768.0;  // the tree's half extent, 1638.4 m
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(1e30, 0, 0), Eigen::Vector3d(0, -1e30, 0), Eigen::Vector3d(0, 0, 3e9),
        Eigen::Vector3d(0, 0, std::numeric_limits<double>::max()), Eigen::Vector3d(edge, 0, 0),
        Eigen::Vector3d(0, -edge, 0)}) {
    EXPECT_EQ(map->Occupancy(p), VoxelState::kUnknown) << p.transpose();
    EXPECT_FALSE(map->ColourAt(p)) << p.transpose();
  }
  EXPECT_EQ(map->Occupancy({edge - 0.1, 0, 0}), VoxelState::kUnknown);  // inside, never seen
  EXPECT_EQ(map->Occupancy({0.01, 0.01, 1.0}), VoxelState::kOccupied);
}

// Found by fuzz_occupancy_ot's round trip: OctoMap writes "res" with 6 significant digits, so a
// map read back from .ot had another resolution (and voxel grid) than the one written.
TEST(OccupancyMapTest, OtKeepsTheExactResolution) {
  for (const double resolution : {0.05, 1.0 / 30.0, 0.0123456789, 0.001}) {
    OccupancyMapOptions options;
    options.resolution_m = resolution;
    StatusOr<OccupancyMap> map = OccupancyMap::Create(options);
    ASSERT_TRUE(map.ok());
    KeyframeCloud cloud;
    cloud.points.emplace_back(0.1F, 0, 0.3F);
    cloud.colours.push_back({10, 20, 30});
    ASSERT_TRUE(map->Insert(cloud, Eigen::Isometry3d::Identity()).ok());
    StatusOr<std::string> ot = map->SerializeOt();
    ASSERT_TRUE(ot.ok());
    StatusOr<OccupancyMap> back = OccupancyMap::DeserializeOt(*ot);
    ASSERT_TRUE(back.ok()) << back.status().ToString();
    EXPECT_EQ(back->resolution(), resolution);
    EXPECT_EQ(back->size(), map->size());
    EXPECT_EQ(*back->SerializeOt(), *ot);
  }
  // The usual resolutions keep OctoMap's short form.
  StatusOr<OccupancyMap> map = OccupancyMap::Create({});
  ASSERT_TRUE(map.ok());
  EXPECT_NE(map->SerializeOt()->find("\nres 0.05\n"), std::string::npos);
}

// Overflow edge of the node count: 2^61 + 1 nodes of 8 bytes is 2^64 + 8 bytes, which wraps to
// the 8 bytes given. Checked, it is a mismatch (DATA_LOSS), never a tree.
TEST(OccupancyMapTest, NodeCountWhoseByteSizeWrapsIsDataLoss) {
  const std::string node("\0\0\0\0\xff\xff\xff\0", 8);  // log-odds 0, white, no children
  for (const char* count : {"2305843009213693953", "2305843009213693952", "9223372036854775807"}) {
    const std::string ot = std::string("# Octomap OcTree file\nid ColorOcTree\nsize ") + count +
                           "\nres 0.05\ndata\n" + node;
    EXPECT_EQ(OccupancyMap::DeserializeOt(ot).status().code(), StatusCode::kDataLoss) << count;
  }
  const std::string one = "# Octomap OcTree file\nid ColorOcTree\nsize 1\nres 0.05\ndata\n" + node;
  StatusOr<OccupancyMap> map = OccupancyMap::DeserializeOt(one);
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  EXPECT_EQ(map->size(), 1U);
}

class DamagedOtTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const std::vector<Keyframe> keyframes = RenderKeyframes(KeyframePoses(60), {});
    StatusOr<OccupancyMap> map =
        OccupancyMap::Build(AtPoses(keyframes, Eigen::Isometry3d::Identity()), {});
    if (!map.ok()) std::abort();
    room_ot = new std::string(*map->SerializeOt());
  }
  static void TearDownTestSuite() { delete room_ot; }

  static bool IsDamageError(const Status& s) {
    return s.code() == StatusCode::kDataLoss || s.code() == StatusCode::kInvalidArgument;
  }

  static std::string* room_ot;
};
std::string* DamagedOtTest::room_ot = nullptr;

TEST_F(DamagedOtTest, TruncatedIsAnError) {
  const std::string& ot = *room_ot;
  ASSERT_GT(ot.size(), 10000U);
  ASSERT_TRUE(OccupancyMap::DeserializeOt(ot).ok());
  std::vector<size_t> lengths;
  for (size_t n = 0; n < 300; ++n) lengths.push_back(n);  // all of the header
  for (size_t n = 300; n < ot.size(); n += 97) lengths.push_back(n);
  for (size_t n = 1; n < 10; ++n) lengths.push_back(ot.size() - n);
  for (size_t n : lengths) {
    const Status s = OccupancyMap::DeserializeOt(std::string_view(ot).substr(0, n)).status();
    EXPECT_TRUE(IsDamageError(s)) << n << ": " << s.ToString();
  }
}

TEST_F(DamagedOtTest, BitFlipsAreErrorsOrValidTreesNeverCrashes) {
  const std::string& ot = *room_ot;
  const size_t data = ot.find("\ndata\n") + 6;
  ASSERT_NE(data, std::string::npos);
  ASSERT_NE(ot.find("\nid ColorOcTree\n"), std::string::npos);
  // Structure damage that must be caught: the header, the root's child bits (after the
  // root's log-odds and colour).
  for (size_t byte : {size_t{0}, size_t{3}, ot.find("size ") + 5, ot.find("id ") + 3, data + 7}) {
    for (int bit = 0; bit < 8; ++bit) {
      std::string bad = ot;
      bad[byte] = static_cast<char>(bad[byte] ^ (1 << bit));
      const Status s = OccupancyMap::DeserializeOt(bad).status();
      EXPECT_TRUE(IsDamageError(s)) << byte << "/" << bit << ": " << s.ToString();
    }
  }
  // Anywhere: an error or a tree, never a crash. Child-bit flips always fail (the node
  // count no longer matches), a flipped log-odds may not: the store's sha256 catches those.
  std::mt19937 rng(7);
  int errors = 0;
  for (int i = 0; i < 2000; ++i) {
    std::string bad = ot;
    const size_t byte = std::uniform_int_distribution<size_t>(0, ot.size() - 1)(rng);
    bad[byte] = static_cast<char>(bad[byte] ^ (1 << (i % 8)));
    const StatusOr<OccupancyMap> r = OccupancyMap::DeserializeOt(bad);
    if (!r.ok()) {
      EXPECT_TRUE(IsDamageError(r.status())) << r.status().ToString();
      ++errors;
    }
  }
  EXPECT_GT(errors, 200);
}

TEST_F(DamagedOtTest, GarbageIsAnError) {
  std::mt19937 rng(3);
  for (size_t n : {0, 1, 21, 100, 5000}) {
    std::string garbage(n, '\0');
    for (char& c : garbage) c = static_cast<char>(rng());
    EXPECT_TRUE(IsDamageError(OccupancyMap::DeserializeOt(garbage).status()));
  }
  // A plausible header over garbage data, and over a node stream that recurses forever.
  const std::string header = "# Octomap OcTree file\nid OcTree\nsize 1000\nres 0.05\ndata\n";
  EXPECT_EQ(OccupancyMap::DeserializeOt(header + std::string(5000, '\xff')).status().code(),
            StatusCode::kDataLoss);
  std::string deep;
  for (int i = 0; i < 1000; ++i) deep += std::string("\0\0\0\0\x01", 5);
  EXPECT_EQ(OccupancyMap::DeserializeOt(header + deep).status().code(), StatusCode::kDataLoss);
  // The same over ColorOcTree records (8 bytes: log-odds, r, g, b, child bits).
  const std::string colour_header =
      "# Octomap OcTree file\nid ColorOcTree\nsize 1000\nres 0.05\ndata\n";
  EXPECT_EQ(OccupancyMap::DeserializeOt(colour_header + std::string(8000, '\xff')).status().code(),
            StatusCode::kDataLoss);
  std::string deep_colour;
  for (int i = 0; i < 1000; ++i) deep_colour += std::string("\0\0\0\0\x10\x20\x30\x01", 8);
  EXPECT_EQ(OccupancyMap::DeserializeOt(colour_header + deep_colour).status().code(),
            StatusCode::kDataLoss);
  // OcTree records under a ColorOcTree header and vice versa: the sizes do not add up.
  EXPECT_EQ(OccupancyMap::DeserializeOt(colour_header + deep).status().code(),
            StatusCode::kDataLoss);
  EXPECT_EQ(OccupancyMap::DeserializeOt(header + deep_colour).status().code(),
            StatusCode::kDataLoss);
  // Other OctoMap tree types are not supported.
  for (const char* id : {"OcTreeStamped", "CountingOcTree", "colorOcTree"}) {
    EXPECT_EQ(OccupancyMap::DeserializeOt(std::string("# Octomap OcTree file\nid ") + id +
                                          "\nsize 0\nres 0.05\ndata\n")
                  .status()
                  .code(),
              StatusCode::kInvalidArgument)
        << id;
  }
  EXPECT_TRUE(
      OccupancyMap::DeserializeOt("# Octomap OcTree file\nid ColorOcTree\nsize 0\nres 0.05\ndata\n")
          .ok());
  EXPECT_EQ(OccupancyMap::DeserializeOt("# Octomap OcTree file\nid OcTree\nsize 0\nres 1e9\ndata\n")
                .status()
                .code(),
            StatusCode::kInvalidArgument);
  // The .bt form is not an .ot.
  StatusOr<OccupancyMap> map = OccupancyMap::DeserializeOt(*room_ot);
  ASSERT_TRUE(map.ok());
  EXPECT_TRUE(IsDamageError(OccupancyMap::DeserializeOt(*map->SerializeBt()).status()));
}

// Not a check: the figures for the issue. Run with --gtest_also_run_disabled_tests.
TEST(OccupancyMapMeasure, DISABLED_InsertionTimeAndMemory) {
  const std::vector<Keyframe> keyframes = RenderKeyframes(KeyframePoses(4), {});
  StatusOr<OccupancyMap> map = OccupancyMap::Create({});
  ASSERT_TRUE(map.ok());
  std::vector<double> ms;
  size_t points = 0;
  for (const Keyframe& k : keyframes) {
    const auto t0 = std::chrono::steady_clock::now();
    ASSERT_TRUE(map->Insert(k.cloud, k.T_world_camera).ok());
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    points += k.cloud.size();
  }
  std::sort(ms.begin(), ms.end());
  const Eigen::AlignedBox3d b = map->Bounds();
  const double volume = b.volume();
  std::printf("%zu keyframes, %.0f points each: insert median %.1f ms, p95 %.1f ms, max %.1f ms\n",
              ms.size(), static_cast<double>(points) / static_cast<double>(ms.size()),
              ms[ms.size() / 2], ms[ms.size() * 95 / 100], ms.back());
  std::printf("tree %zu nodes, %.2f MB, bounds %.2f m^3 -> %.1f kB per m^3; .ot %zu B, .bt %zu B\n",
              map->size(), static_cast<double>(map->MemoryBytes()) / 1e6, volume,
              static_cast<double>(map->MemoryBytes()) / 1e3 / volume, map->SerializeOt()->size(),
              map->SerializeBt()->size());
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> all;
  all.reserve(keyframes.size());
  for (const Keyframe& k : keyframes) all.emplace_back(&k.cloud, k.T_world_camera);
  ASSERT_TRUE(OccupancyMap::Build(all, {}).ok());
  std::printf(
      "rebuild of %zu keyframes: %.0f ms\n", all.size(),
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
}

}  // namespace
}  // namespace semmap
