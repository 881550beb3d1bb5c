// The 3D map end to end: a synthetic lap of the default room streamed in RGBD mode into semmapd,
// then `semmap export` in every layer format. The exported OctoMap has the generator's walls
// where they are (in the map frame, the first camera's), the PLY/PCD clouds read back with PCL,
// the picture decodes, and a restarted server exports the same map. With the shared data, the
// same for TUM fr3/teddy.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include <csignal>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "client/datasets/trajectory_io.h"
#include "core/mapping/occupancy_map.h"
#include "tests/testing/server_process.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

using testing::RunCommand;
using testing::SemmapCliPath;

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// `semmap export` into dir/name.format; returns the CLI's JSON answer (empty on failure).
nlohmann::json Export(const testing::ServerProcess& server, const std::string& map,
                      const std::string& format, const std::string& path,
                      const std::vector<std::string>& extra = {}) {
  std::vector<std::string> argv = {SemmapCliPath(),
                                   "--server",
                                   server.address(),
                                   "--json",
                                   "export",
                                   "--map",
                                   map,
                                   "--format",
                                   format,
                                   "-o",
                                   path};
  argv.insert(argv.end(), extra.begin(), extra.end());
  std::string out;
  const int rc = RunCommand(argv, &out);
  EXPECT_EQ(rc, 0) << format << ": " << out;
  return rc == 0 ? nlohmann::json::parse(out) : nlohmann::json();
}

// Every layer format reads back with the standard libraries; returns the .ot's sha256.
std::string ExportAndReadBack(const testing::ServerProcess& server, const std::string& map,
                              const testing::TempDir& dir, size_t min_points) {
  const std::string ot = dir.File(map + ".ot");
  const nlohmann::json ot_info = Export(server, map, "ot", ot);
  std::ifstream ot_in(ot, std::ios::binary);
  std::unique_ptr<octomap::AbstractOcTree> tree(octomap::AbstractOcTree::read(ot_in));
  EXPECT_NE(tree, nullptr);
  if (tree) {
    EXPECT_GT(tree->size(), 1000u);
  }

  const std::string bt = dir.File(map + ".bt");
  Export(server, map, "bt", bt);
  octomap::OcTree bt_tree(0.1);
  EXPECT_TRUE(bt_tree.readBinary(bt));
  EXPECT_GT(bt_tree.size(), 100u);

  for (const bool ascii : {false, true}) {
    const std::vector<std::string> extra =
        ascii ? std::vector<std::string>{"--ascii"} : std::vector<std::string>{};
    pcl::PointCloud<pcl::PointXYZRGB> ply, pcd;
    const std::string suffix = ascii ? "-ascii" : "";
    Export(server, map, "ply", dir.File(map + suffix + ".ply"), extra);
    Export(server, map, "pcd", dir.File(map + suffix + ".pcd"), extra);
    EXPECT_EQ(pcl::io::loadPLYFile(dir.File(map + suffix + ".ply"), ply), 0);
    EXPECT_EQ(pcl::io::loadPCDFile(dir.File(map + suffix + ".pcd"), pcd), 0);
    EXPECT_GE(ply.size(), min_points);
    EXPECT_EQ(ply.size(), pcd.size());
  }

  const std::string png = dir.File(map + ".png");
  Export(server, map, "png", png);
  const cv::Mat image = cv::imread(png, cv::IMREAD_COLOR);
  EXPECT_FALSE(image.empty());
  EXPECT_EQ(std::max(image.cols, image.rows), 1600);
  Export(server, map, "png", dir.File(map + "-oblique.png"),
         {"--view", "oblique", "--width", "800"});
  const cv::Mat oblique = cv::imread(dir.File(map + "-oblique.png"), cv::IMREAD_COLOR);
  EXPECT_EQ(std::max(oblique.cols, oblique.rows), 800);
  return ot_info.is_null() ? "" : ot_info["sha256"].get<std::string>();
}

// A surface point at a voxel boundary lands on either side: occupied within a voxel and a half.
bool OccupiedNear(const OccupancyMap& map, const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  for (const double k : {0.0, 0.5, -0.5, 1.0, -1.0, 1.5, -1.5}) {
    if (map.Occupancy(p + k * map.resolution() * n) == VoxelState::kOccupied) return true;
  }
  return false;
}

TEST(MapExportE2ETest, SyntheticLapExportsInEveryFormatAndSurvivesARestart) {
  testing::TempDir dir;
  const std::string seq = dir.File("lap");
  std::string out;
  ASSERT_EQ(RunCommand({std::string(SEMMAP_BINARY_DIR) + "/tools/semmap-synth", seq, "--frames",
                        "300", "--depth-noise", "--quiet"},
                       &out),
            0)
      << out;
  testing::ServerProcess server;
  ASSERT_TRUE(server.Start(dir.File("data")).ok());
  ASSERT_EQ(RunCommand({SemmapCliPath(), "--server", server.address(), "--json", "ingest", seq,
                        "--map", "room"},
                       &out),
            0)
      << out;
  const std::string sha = ExportAndReadBack(server, "room", dir, 20000);

  // The generator's walls are occupied where they are, in the map frame (the first camera's).
  StatusOr<std::vector<StampedPose>> gt = ReadTumTrajectory(seq + "/groundtruth.txt");
  ASSERT_TRUE(gt.ok());
  const Eigen::Isometry3d T_map_world = gt->front().T_world_camera.inverse();
  StatusOr<OccupancyMap> map = OccupancyMap::DeserializeOt(ReadFile(dir.File("room.ot")));
  ASSERT_TRUE(map.ok()) << map.status().ToString();
  const auto at = [&](double x, double y, double z) {
    return T_map_world * Eigen::Vector3d(x, y, z);
  };
  const Eigen::Vector3d nx = T_map_world.linear() * Eigen::Vector3d::UnitX();
  const Eigen::Vector3d ny = T_map_world.linear() * Eigen::Vector3d::UnitY();
  EXPECT_TRUE(OccupiedNear(*map, at(3.0, 0.8, 1.4), nx));
  EXPECT_TRUE(OccupiedNear(*map, at(-3.0, -1.5, 1.4), nx));
  EXPECT_TRUE(OccupiedNear(*map, at(-1.5, 2.5, 1.4), ny));
  EXPECT_TRUE(OccupiedNear(*map, at(1.5, -2.5, 1.4), ny));
  // Between the cameras and the walls: free.
  EXPECT_EQ(map->Occupancy(at(2.0, 0.8, 1.4)), VoxelState::kFree);

  // A coarser leaf has fewer points.
  const nlohmann::json coarse =
      Export(server, "room", "pcd", dir.File("coarse.pcd"), {"--voxel", "0.1"});
  const nlohmann::json fine = Export(server, "room", "pcd", dir.File("fine.pcd"));
  ASSERT_FALSE(coarse.is_null() || fine.is_null());
  EXPECT_LT(coarse["bytes"].get<size_t>(), fine["bytes"].get<size_t>() / 4);
  EXPECT_EQ(server.Stop(SIGTERM), 0);

  // A restarted server has the same map.
  ASSERT_TRUE(server.Start(dir.File("data")).ok());
  const nlohmann::json again = Export(server, "room", "ot", dir.File("again.ot"));
  ASSERT_FALSE(again.is_null());
  EXPECT_EQ(again["sha256"], sha);
  // Unknown maps and formats are clear errors, not crashes.
  EXPECT_NE(RunCommand({SemmapCliPath(), "--server", server.address(), "export", "--map", "nope",
                        "--format", "ply", "-o", dir.File("x.ply")},
                       &out),
            0);
  EXPECT_NE(RunCommand({SemmapCliPath(), "--server", server.address(), "export", "--map", "room",
                        "--format", "obj", "-o", dir.File("x.obj")},
                       &out),
            0);
  EXPECT_EQ(server.Stop(SIGTERM), 0);
}

TEST(MapExportE2ETest, TeddyExportsInEveryFormat) {
  const std::string data = testing::SharedDataDir();
  if (data.empty()) GTEST_SKIP() << "shared data not found (../shared/data): skipping teddy export";
  testing::TempDir dir;
  testing::ServerProcess server;
  ASSERT_TRUE(server.Start(dir.File("data")).ok());
  std::string out;
  ASSERT_EQ(RunCommand({SemmapCliPath(), "--server", server.address(), "--json", "ingest",
                        data + "/tum_fr3_teddy_200", "--map", "teddy"},
                       &out),
            0)
      << out;
  EXPECT_FALSE(ExportAndReadBack(server, "teddy", dir, 20000).empty());
  EXPECT_EQ(server.Stop(SIGTERM), 0);
}

}  // namespace
}  // namespace semmap
