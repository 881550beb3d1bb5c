// PointCloudMap: known answers from hand-made keyframe clouds (points at leaf centres, known
// colours, known poses), leaf means, merging, rigid moves, and PLY/PCD exports read back with
// PCL's own readers.
#include "core/mapping/point_cloud_map.h"

#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "core/mapping/cloud_pcd_reader.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

using Keyframes = std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>>;

Eigen::Isometry3d Pose(double yaw, double pitch, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  T.translation() = t;
  return T;
}

// A keyframe cloud holding world points seen from T_world_keyframe, colour (r, g, b) given.
KeyframeCloud CloudFromWorld(const std::vector<Eigen::Vector3d>& world,
                             const Eigen::Isometry3d& T_world_keyframe,
                             const std::vector<std::array<uint8_t, 3>>& rgb) {
  KeyframeCloud cloud;
  const Eigen::Isometry3d T_keyframe_world = T_world_keyframe.inverse();
  for (size_t i = 0; i < world.size(); ++i) {
    cloud.points.emplace_back((T_keyframe_world * world[i]).cast<float>());
    cloud.colours.push_back({rgb[i][2], rgb[i][1], rgb[i][0]});  // BGR
  }
  return cloud;
}

// Leaf centres of a plane z = z0 over [0, nx) x [0, ny) leaves.
std::vector<Eigen::Vector3d> PlaneLeafCentres(int nx, int ny, double leaf, double z0) {
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j < ny; ++j) out.emplace_back((i + 0.5) * leaf, (j + 0.5) * leaf, z0);
  }
  return out;
}

std::array<uint8_t, 3> ColourOf(const Eigen::Vector3d& p, int offset = 0) {
  const int k = static_cast<int>(std::lround(p.x() * 100 + p.y() * 37));
  return {static_cast<uint8_t>((k * 7) % 200 + offset),
          static_cast<uint8_t>((k * 13) % 200 + offset),
          static_cast<uint8_t>((k * 29) % 200 + offset)};
}

// The map's point nearest to p (the maps here are small).
const CloudPoint* Nearest(const PointCloudMap& map, const Eigen::Vector3d& p, double* distance) {
  const CloudPoint* best = nullptr;
  double best_d = std::numeric_limits<double>::infinity();
  for (const CloudPoint& q : map.points()) {
    const double d = (Eigen::Vector3d(q.x, q.y, q.z) - p).norm();
    if (d < best_d) {
      best_d = d;
      best = &q;
    }
  }
  *distance = best_d;
  return best;
}

std::string WriteFile(const testing::TempDir& dir, const std::string& name,
                      const std::string& bytes) {
  std::string path = dir.File(name);
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path;
}

TEST(PointCloudMapOptionsTest, Validate) {
  EXPECT_TRUE(PointCloudMapOptions{}.Validate().ok());
  EXPECT_TRUE(PointCloudMapOptions{0.001}.Validate().ok());
  EXPECT_TRUE(PointCloudMapOptions{1.0}.Validate().ok());
  for (double bad :
       {0.0, -0.02, 0.0009, 1.5, std::nan(""), std::numeric_limits<double>::infinity()}) {
    EXPECT_EQ(PointCloudMapOptions{bad}.Validate().code(), StatusCode::kInvalidArgument) << bad;
  }
  EXPECT_EQ(PointCloudMap::Build({}, PointCloudMapOptions{0.0}).status().code(),
            StatusCode::kInvalidArgument);
}

TEST(PointCloudMapTest, RejectsBadKeyframes) {
  KeyframeCloud ok_cloud;
  ok_cloud.points = {Eigen::Vector3f(0, 0, 1)};
  ok_cloud.colours = {{1, 2, 3}};
  KeyframeCloud mismatched = ok_cloud;
  mismatched.colours.clear();
  Eigen::Isometry3d nan_pose = Eigen::Isometry3d::Identity();
  nan_pose.translation().x() = std::nan("");
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  EXPECT_EQ(PointCloudMap::Build({{nullptr, I}}, {}).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(PointCloudMap::Build({{&ok_cloud, I}, {&mismatched, I}}, {}).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(PointCloudMap::Build({{&ok_cloud, nan_pose}}, {}).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_TRUE(PointCloudMap::Build({{&ok_cloud, I}}, {}).ok());
}

TEST(PointCloudMapTest, WorldPointsWhereExpected) {
  const double leaf = 0.02;
  // A box's floor and one wall, 0.1 m apart (each point in a leaf of its own), at leaf centres.
  std::vector<Eigen::Vector3d> world = PlaneLeafCentres(6, 4, 0.1, 0.01);
  for (int i = 0; i < 6; ++i) {
    for (int k = 1; k < 4; ++k) world.emplace_back((i + 0.5) * 0.1, 0.01, k * 0.1 + 0.01);
  }
  std::vector<std::array<uint8_t, 3>> rgb;
  rgb.reserve(world.size());
  for (const Eigen::Vector3d& p : world) rgb.push_back(ColourOf(p));
  const Eigen::Isometry3d T_world_keyframe = Pose(0.7, -0.3, {1.0, -2.0, 1.5});
  const KeyframeCloud cloud = CloudFromWorld(world, T_world_keyframe, rgb);

  StatusOr<PointCloudMap> map = PointCloudMap::Build({{&cloud, T_world_keyframe}}, {leaf});
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  ASSERT_EQ(map->size(), world.size());
  for (size_t i = 0; i < world.size(); ++i) {
    double d = 0;
    const CloudPoint* q = Nearest(*map, world[i], &d);
    ASSERT_NE(q, nullptr);
    EXPECT_LT(d, 1e-5) << i;
    EXPECT_EQ(std::make_tuple(q->r, q->g, q->b), std::make_tuple(rgb[i][0], rgb[i][1], rgb[i][2]))
        << i;
  }
  const Eigen::AlignedBox3d bounds = map->Bounds();
  EXPECT_NEAR(bounds.min().x(), 0.05, 1e-5);
  EXPECT_NEAR(bounds.max().x(), 0.55, 1e-5);
  EXPECT_NEAR(bounds.min().y(), 0.01, 1e-5);
  EXPECT_NEAR(bounds.max().y(), 0.35, 1e-5);
  EXPECT_NEAR(bounds.min().z(), 0.01, 1e-5);
  EXPECT_NEAR(bounds.max().z(), 0.31, 1e-5);
}

TEST(PointCloudMapTest, OnePointPerLeafWithMeanPositionAndColour) {
  // Leaf 0.1: four points in leaf [0, 0.1)^3, one in leaf [0.2, 0.3) x [0, 0.1)^2.
  KeyframeCloud cloud;
  cloud.points = {{0.01f, 0.02f, 0.03f},
                  {0.03f, 0.04f, 0.05f},
                  {0.05f, 0.06f, 0.07f},
                  {0.07f, 0.08f, 0.09f},
                  {0.25f, 0.05f, 0.05f}};
  // BGR; RGB means of the first four: (25, 35, 45).
  cloud.colours = {{30, 20, 10}, {40, 30, 20}, {50, 40, 30}, {60, 50, 40}, {3, 2, 1}};
  StatusOr<PointCloudMap> map =
      PointCloudMap::Build({{&cloud, Eigen::Isometry3d::Identity()}}, {0.1});
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  ASSERT_EQ(map->size(), 2u);
  double d = 0;
  const CloudPoint* mean = Nearest(*map, {0.04, 0.05, 0.06}, &d);
  EXPECT_LT(d, 1e-6);
  EXPECT_EQ(std::make_tuple(mean->r, mean->g, mean->b), std::make_tuple(25, 35, 45));
  const CloudPoint* single = Nearest(*map, {0.25, 0.05, 0.05}, &d);
  EXPECT_LT(d, 1e-6);
  EXPECT_EQ(std::make_tuple(single->r, single->g, single->b), std::make_tuple(1, 2, 3));
}

// A map of more points than one piece holds is filtered slab by slab, never as one cloud; the
// result is the one-piece filter's (every leaf falls wholly into one slab).
TEST(PointCloudMapTest, ManyPointsAreFilteredInSlabsWithTheOnePieceResult) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coordinate(-2.0f, 2.0f);
  std::vector<KeyframeCloud> clouds(4);
  std::vector<std::pair<const KeyframeCloud*, Eigen::Isometry3d>> placed;
  for (size_t k = 0; k < clouds.size(); ++k) {
    for (int i = 0; i < 3000; ++i) {
      clouds[k].points.emplace_back(coordinate(rng), coordinate(rng), coordinate(rng));
      clouds[k].colours.push_back({static_cast<uint8_t>(k * 40), 7, 9});
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = static_cast<double>(k);
    placed.emplace_back(&clouds[k], T);
  }
  PointCloudMapOptions one_piece{0.1};
  PointCloudMapOptions slabs{0.1};
  slabs.max_points_per_piece = 1000;  // 12000 points: at least 12 slabs
  StatusOr<PointCloudMap> whole = PointCloudMap::Build(placed, one_piece);
  StatusOr<PointCloudMap> sliced = PointCloudMap::Build(placed, slabs);
  ASSERT_TRUE(whole.ok() && sliced.ok());
  ASSERT_GT(whole->size(), 1000u);
  auto sorted = [](const PointCloudMap& map) {
    std::vector<std::tuple<float, float, float, int, int, int>> out;
    for (const CloudPoint& p : map.points()) out.emplace_back(p.x, p.y, p.z, p.r, p.g, p.b);
    std::sort(out.begin(), out.end());
    return out;
  };
  const auto a = sorted(*whole);
  const auto b = sorted(*sliced);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(std::get<0>(a[i]), std::get<0>(b[i]), 1e-5);
    EXPECT_NEAR(std::get<1>(a[i]), std::get<1>(b[i]), 1e-5);
    EXPECT_NEAR(std::get<2>(a[i]), std::get<2>(b[i]), 1e-5);
    EXPECT_EQ(std::get<3>(a[i]), std::get<3>(b[i]));
  }
  slabs.max_points_per_piece = 10;
  EXPECT_EQ(PointCloudMap::Build(placed, slabs).status().code(), StatusCode::kInvalidArgument);
}

TEST(PointCloudMapTest, TwoKeyframesSeeingTheSameSurfaceMerge) {
  const double leaf = 0.05;
  const std::vector<Eigen::Vector3d> floor = PlaneLeafCentres(20, 10, leaf, -leaf / 2);
  // A sees x < 0.6, B sees x > 0.4: 4 columns of 10 leaves seen by both.
  std::vector<Eigen::Vector3d> seen_a, seen_b;
  std::vector<std::array<uint8_t, 3>> rgb_a, rgb_b;
  for (const Eigen::Vector3d& p : floor) {
    if (p.x() < 0.6) {
      seen_a.push_back(p);
      rgb_a.push_back(ColourOf(p, 0));
    }
    if (p.x() > 0.4) {
      seen_b.push_back(p);
      rgb_b.push_back(ColourOf(p, 2));
    }
  }
  const Eigen::Isometry3d T_world_a = Pose(0.2, 0.9, {0.1, 0.2, 1.2});
  const Eigen::Isometry3d T_world_b = Pose(2.5, 1.1, {1.0, 0.3, 1.0});
  const KeyframeCloud a = CloudFromWorld(seen_a, T_world_a, rgb_a);
  const KeyframeCloud b = CloudFromWorld(seen_b, T_world_b, rgb_b);

  StatusOr<PointCloudMap> map = PointCloudMap::Build({{&a, T_world_a}, {&b, T_world_b}}, {leaf});
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  EXPECT_EQ(seen_a.size() + seen_b.size(), 240u);
  ASSERT_EQ(map->size(), floor.size());  // 200, not 240
  for (const Eigen::Vector3d& p : floor) {
    double d = 0;
    const CloudPoint* q = Nearest(*map, p, &d);
    EXPECT_LT(d, 1e-5);
    const bool both = p.x() > 0.4 && p.x() < 0.6;
    const std::array<uint8_t, 3> expected = ColourOf(p, both ? 1 : (p.x() < 0.6 ? 0 : 2));
    EXPECT_EQ(std::make_tuple(q->r, q->g, q->b),
              std::make_tuple(expected[0], expected[1], expected[2]))
        << p.transpose();
  }
}

TEST(PointCloudMapTest, MovedPosesMoveTheCloudRigidly) {
  const double leaf = 0.05;
  std::vector<Eigen::Vector3d> world = PlaneLeafCentres(8, 6, leaf, 0.025);
  for (int i = 0; i < 8; ++i) {
    for (int k = 1; k < 5; ++k) world.emplace_back((i + 0.5) * leaf, 0.025, (k + 0.5) * leaf);
  }
  std::vector<std::array<uint8_t, 3>> rgb;
  rgb.reserve(world.size());
  for (const Eigen::Vector3d& p : world) rgb.push_back(ColourOf(p));
  const Eigen::Isometry3d T_world_k = Pose(-0.4, 0.6, {0.3, 0.1, 1.4});
  const KeyframeCloud cloud = CloudFromWorld(world, T_world_k, rgb);
  // A correction mapping leaf centres to leaf centres: quarter turn about z plus whole leaves.
  const Eigen::Isometry3d correction = Pose(M_PI / 2, 0, {0.5, -0.25, 1.0});

  StatusOr<PointCloudMap> before = PointCloudMap::Build({{&cloud, T_world_k}}, {leaf});
  StatusOr<PointCloudMap> after = PointCloudMap::Build({{&cloud, correction * T_world_k}}, {leaf});
  ASSERT_TRUE(before.ok() && after.ok());
  ASSERT_EQ(before->size(), world.size());
  ASSERT_EQ(after->size(), world.size());
  for (const CloudPoint& p : before->points()) {
    double d = 0;
    const CloudPoint* q = Nearest(*after, correction * Eigen::Vector3d(p.x, p.y, p.z), &d);
    EXPECT_LT(d, 1e-5);
    EXPECT_EQ(std::make_tuple(q->r, q->g, q->b), std::make_tuple(p.r, p.g, p.b));
  }
  const Eigen::AlignedBox3d moved = before->Bounds().transformed(correction);
  EXPECT_TRUE(moved.min().isApprox(after->Bounds().min(), 1e-5));
  EXPECT_TRUE(moved.max().isApprox(after->Bounds().max(), 1e-5));
}

TEST(PointCloudMapTest, HugeExtentIsStillFiltered) {
  // 300 m x 3 m x 2 m at 1 mm leaves: beyond PCL's 32-bit leaf index (which would pass the
  // input through unfiltered), so filtered in slabs.
  KeyframeCloud cloud;
  for (int i = 0; i < 4; ++i) {
    const float o = 0.0002f + 0.0002f * static_cast<float>(i);
    cloud.points.emplace_back(o, o, o);
    cloud.points.emplace_back(300.0f + 0.25f, 3.0f + o, 2.0f + o);
    cloud.colours.push_back({10, 10, 10});
    cloud.colours.push_back({20, 20, 20});
  }
  StatusOr<PointCloudMap> map =
      PointCloudMap::Build({{&cloud, Eigen::Isometry3d::Identity()}}, {0.001});
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  EXPECT_EQ(map->size(), 2u);
}

TEST(PointCloudMapTest, EmptyInputGivesEmptyMapWithValidExports) {
  KeyframeCloud empty_cloud;
  for (const Keyframes& keyframes :
       {Keyframes{}, Keyframes{{&empty_cloud, Eigen::Isometry3d::Identity()}}}) {
    StatusOr<PointCloudMap> map = PointCloudMap::Build(keyframes, {});
    ASSERT_TRUE(map.ok()) << map.status().ToString();
    EXPECT_EQ(map->size(), 0u);
    EXPECT_TRUE(map->empty());
    EXPECT_TRUE(map->Bounds().isEmpty());
  }
  const PointCloudMap map;
  testing::TempDir dir;
  for (bool binary : {true, false}) {
    StatusOr<std::string> ply = map.ToPly(binary);
    ASSERT_TRUE(ply.ok());
    EXPECT_NE(ply->find("element vertex 0\n"), std::string::npos);
    // Read as PCLPointCloud2: PCL 1.13's templated conversion indexes element 0 of an empty
    // cloud (undefined behaviour that UBSan reports inside PCL's headers).
    pcl::PCLPointCloud2 from_ply;
    EXPECT_EQ(pcl::io::loadPLYFile(WriteFile(dir, "empty.ply", *ply), from_ply), 0) << binary;
    EXPECT_EQ(from_ply.width * from_ply.height, 0u);

    StatusOr<std::string> pcd = map.ToPcd(binary);
    ASSERT_TRUE(pcd.ok());
    pcl::PCLPointCloud2 from_pcd;
    EXPECT_EQ(pcl::io::loadPCDFile(WriteFile(dir, "empty.pcd", *pcd), from_pcd), 0) << binary;
    EXPECT_EQ(from_pcd.width * from_pcd.height, 0u);
  }
}

class ExportTest : public ::testing::TestWithParam<bool> {};

TEST_P(ExportTest, PlyAndPcdReadBackWithPcl) {
  const bool binary = GetParam();
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> coordinate(-3.0f, 3.0f);
  std::uniform_int_distribution<int> channel(0, 255);
  KeyframeCloud cloud;
  for (int i = 0; i < 500; ++i) {
    cloud.points.emplace_back(coordinate(rng), coordinate(rng), coordinate(rng) + 4.0f);
    cloud.colours.push_back({static_cast<uint8_t>(channel(rng)), static_cast<uint8_t>(channel(rng)),
                             static_cast<uint8_t>(channel(rng))});
  }
  cloud.colours[0] = {0, 0, 0};
  cloud.colours[1] = {255, 255, 255};
  StatusOr<PointCloudMap> map =
      PointCloudMap::Build({{&cloud, Pose(0.3, 0.2, {-1, 2, 0.5})}}, {0.01});
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  ASSERT_GT(map->size(), 400u);

  StatusOr<std::string> ply = map->ToPly(binary);
  StatusOr<std::string> pcd = map->ToPcd(binary);
  ASSERT_TRUE(ply.ok() && pcd.ok());
  EXPECT_EQ(
      ply->rfind(binary ? "ply\nformat binary_little_endian 1.0\n" : "ply\nformat ascii 1.0\n", 0),
      0u);
  EXPECT_NE(pcd->find(binary ? "\nDATA binary\n" : "\nDATA ascii\n"), std::string::npos);
  if (binary) {
    EXPECT_EQ(ply->size() - (ply->find("end_header\n") + 11), map->size() * 15);
    EXPECT_EQ(pcd->size() - (pcd->find("DATA binary\n") + 12), map->size() * 16);
  }

  testing::TempDir dir;
  pcl::PointCloud<pcl::PointXYZRGB> from_ply, from_pcd;
  ASSERT_EQ(pcl::io::loadPLYFile(WriteFile(dir, "map.ply", *ply), from_ply), 0);
  ASSERT_EQ(pcl::io::loadPCDFile(WriteFile(dir, "map.pcd", *pcd), from_pcd), 0);
  ASSERT_EQ(from_ply.size(), map->size());
  ASSERT_EQ(from_pcd.size(), map->size());
  for (size_t i = 0; i < map->size(); ++i) {
    const CloudPoint& p = map->points()[i];
    for (const pcl::PointCloud<pcl::PointXYZRGB>* loaded : {&from_ply, &from_pcd}) {
      const pcl::PointXYZRGB& q = (*loaded)[i];
      // Exact: binary is the same bits, ASCII floats are shortest round-trip.
      ASSERT_EQ(std::make_tuple(q.x, q.y, q.z), std::make_tuple(p.x, p.y, p.z)) << i;
      ASSERT_EQ(std::make_tuple(q.r, q.g, q.b), std::make_tuple(p.r, p.g, p.b)) << i;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(BinaryAndAscii, ExportTest, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& param) {
                           return param.param ? "Binary" : "Ascii";
                         });

// Overflow edge of the PCD reader's size check: POINTS 2^60 + 1 of 16 bytes is 2^64 + 16 bytes,
// which wraps to the 16 bytes given; reading that many points would allocate without bound.
TEST(CloudPcdReaderTest, PointCountWhoseByteSizeWrapsIsDataLoss) {
  StatusOr<std::string> one = PointCloudMap::FromPoints({{1, 2, 3, 4, 5, 6}}, {}).ToPcd(true);
  ASSERT_TRUE(one.ok());
  StatusOr<std::vector<CloudPoint>> read = ReadCloudPcd(*one);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ASSERT_EQ(read->size(), 1U);
  for (const std::string count :
       {"1152921504606846977", "1152921504606846976", "18446744073709551615"}) {
    std::string pcd = *one;
    for (const std::string key : {"WIDTH 1\n", "POINTS 1\n"}) {
      const size_t at = pcd.find(key);
      ASSERT_NE(at, std::string::npos);
      pcd.replace(at, key.size(), key.substr(0, key.size() - 2) + count + "\n");
    }
    EXPECT_EQ(ReadCloudPcd(pcd).status().code(), StatusCode::kDataLoss) << count;
  }
}

}  // namespace
}  // namespace semmap
