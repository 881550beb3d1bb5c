// Objects end to end through semmapd and the semmap CLI: register object photos, stream RGBD,
// ask `where` and `near`. On the synthetic room every named object is found once, within 5 cm
// of its box, with no false labels; with the shared data, the teddy registered from a crop of
// the first TUM fr3/teddy frame is found once within 0.10 m of its true position, and the café
// sequence (no teddy in it) gives no teddy.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <csignal>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "client/datasets/trajectory_io.h"
#include "tests/testing/server_process.h"
#include "tests/testing/temp_dir.h"
#include "tests/testing/text_lines.h"

namespace semmap {
namespace {

using testing::RunCommand;
using testing::SemmapCliPath;

struct Cli {
  std::string server;
  // Runs `semmap --server S --json ARGS`; the parsed answer, or null when it failed.
  nlohmann::json Json(std::vector<std::string> args, int* rc = nullptr) const {
    std::vector<std::string> argv = {SemmapCliPath(), "--server", server, "--json"};
    argv.insert(argv.end(), args.begin(), args.end());
    std::string out;
    const int code = RunCommand(argv, &out);
    if (rc) *rc = code;
    if (code != 0) return nullptr;
    return nlohmann::json::parse(out, nullptr, /*allow_exceptions=*/false);
  }
};

Eigen::Vector3d Position(const nlohmann::json& object) {
  const auto& p = object["position"];
  return {p["x"].get<double>(), p["y"].get<double>(), p["z"].get<double>()};
}

struct SceneObject {
  Eigen::Vector3d centre, size;  // world frame, axis-aligned box
};

// objects.txt of semmap-synth: label cx cy cz sx sy sz.
std::map<std::string, SceneObject> ReadSceneObjects(const std::string& path) {
  std::map<std::string, SceneObject> out;
  for (const std::string& line : testing::DataLines(path)) {
    std::istringstream in(line);
    std::string label;
    SceneObject o;
    in >> label >> o.centre.x() >> o.centre.y() >> o.centre.z() >> o.size.x() >> o.size.y() >>
        o.size.z();
    out[label] = o;
  }
  return out;
}

// Distance from p to the box (0 inside).
double DistanceToBox(const Eigen::Vector3d& p, const SceneObject& box) {
  const Eigen::Vector3d d =
      ((p - box.centre).cwiseAbs() - 0.5 * box.size).cwiseMax(Eigen::Vector3d::Zero());
  return d.norm();
}

// Two sessions into one map: a lap of the room (sees the book and the poster from 1.5-2 m) and
// a tour that stops 1 m in front of each named object; the second joins the first one's frame
// by loop closure, and the objects it saw move with it.
TEST(ObjectsE2ETest, SyntheticRoomObjectsAreFoundWhereTheyAre) {
  testing::TempDir dir;
  const std::string seq = dir.File("lap");
  const std::string tour = dir.File("tour");
  std::string out;
  for (const auto& [path, kind, frames] :
       {std::tuple{seq, "circle", "300"}, std::tuple{tour, "tour", "400"}}) {
    ASSERT_EQ(
        RunCommand({std::string(SEMMAP_BINARY_DIR) + "/tools/semmap-synth", path, "--trajectory",
                    kind, "--frames", frames, "--depth-noise", "--colour-noise", "--quiet"},
                   &out),
        0)
        << out;
  }
  const std::map<std::string, SceneObject> truth = ReadSceneObjects(seq + "/objects.txt");
  ASSERT_EQ(truth.size(), 4u);

  testing::ServerProcess server;
  ASSERT_TRUE(server.Start(dir.File("data")).ok());
  const Cli cli{server.address()};
  for (const auto& [label, object] : truth) {
    const nlohmann::json added =
        cli.Json({"objects", "add", label,
                  std::string(seq).append("/objects/").append(label).append(".png")});
    ASSERT_FALSE(added.is_null()) << label;
    EXPECT_EQ(added["object"]["label"], label);
  }
  // Bad input is refused with the reason, not stored.
  int rc = 0;
  cli.Json({"objects", "add", "book", seq + "/objects/book.png"}, &rc);
  EXPECT_EQ(rc, 1);  // ALREADY_EXISTS
  {
    std::ofstream garbage(dir.File("garbage.png"));
    garbage << "not an image";
  }
  cli.Json({"objects", "add", "garbage", dir.File("garbage.png")}, &rc);
  EXPECT_EQ(rc, 1);  // INVALID_ARGUMENT
  cv::imwrite(dir.File("plain.png"), cv::Mat(200, 200, CV_8UC3, cv::Scalar(90, 90, 90)));
  cli.Json({"objects", "add", "plain", dir.File("plain.png")}, &rc);
  EXPECT_EQ(rc, 1);  // too few features
  const nlohmann::json listed = cli.Json({"objects", "list"});
  ASSERT_FALSE(listed.is_null());
  EXPECT_EQ(listed["objects"].size(), 4u);

  ASSERT_FALSE(cli.Json({"ingest", seq, "--map", "room", "--session", "lap"}).is_null());
  ASSERT_FALSE(cli.Json({"ingest", tour, "--map", "room", "--session", "tour"}).is_null());
  StatusOr<std::vector<StampedPose>> gt = ReadTumTrajectory(seq + "/groundtruth.txt");
  ASSERT_TRUE(gt.ok());
  // The map frame is the first camera's.
  const Eigen::Isometry3d T_map_world = gt->front().T_world_camera.inverse();

  const nlohmann::json all = cli.Json({"where", "--map", "room"});
  ASSERT_FALSE(all.is_null());
  std::map<std::string, int> counts;
  for (const auto& o : all["objects"]) ++counts[o["label"].get<std::string>()];
  for (const auto& [label, object] : truth) {
    const nlohmann::json found = cli.Json({"where", label});
    ASSERT_FALSE(found.is_null()) << label;
    ASSERT_EQ(found["objects"].size(), 1u) << label << ": " << found.dump();
    const Eigen::Vector3d p_world = T_map_world.inverse() * Position(found["objects"][0]);
    const double error = DistanceToBox(p_world, object);
    std::printf("%-10s found %d times, %.3f m from its box\n", label.c_str(),
                found["objects"][0]["observations"].get<int>(), error);
    EXPECT_LT(error, 0.05) << label;
    EXPECT_EQ(counts[label], 1) << label;
  }
  EXPECT_EQ(counts.size(), truth.size()) << all.dump();  // no other labels
  // The poster is on the lap and the tour: one instance seen by both sessions.
  const nlohmann::json poster = cli.Json({"where", "mug_poster"});
  ASSERT_EQ(poster["objects"].size(), 1u);
  EXPECT_EQ(poster["objects"][0]["sessions"].size(), 2u) << poster.dump();

  // near: from the book's position, the book is first and at distance ~0.
  const Eigen::Vector3d book = T_map_world * truth.at("book").centre;
  const nlohmann::json near = cli.Json({"near", std::to_string(book.x()), std::to_string(book.y()),
                                        std::to_string(book.z()), "0.5", "--map", "room"});
  ASSERT_FALSE(near.is_null());
  ASSERT_GE(near["objects"].size(), 1u);
  EXPECT_EQ(near["objects"][0]["label"], "book");
  EXPECT_LT(near["objects"][0]["distance"].get<double>(), 0.1);
  const nlohmann::json far = cli.Json({"near", "100", "100", "100", "1", "--map", "room"});
  ASSERT_FALSE(far.is_null());
  EXPECT_EQ(far["objects"].size(), 0u);
  cli.Json({"near", "0", "0", "0", "-1"}, &rc);
  EXPECT_EQ(rc, 2);

  // A restarted server answers the same; a removed type is gone with its instances.
  EXPECT_EQ(server.Stop(SIGTERM), 0);
  ASSERT_TRUE(server.Start(dir.File("data")).ok());
  const Cli again{server.address()};
  const nlohmann::json laptop = again.Json({"where", "laptop"});
  ASSERT_FALSE(laptop.is_null());
  EXPECT_EQ(laptop["objects"].size(), 1u);
  ASSERT_FALSE(again.Json({"objects", "remove", "laptop"}).is_null());
  EXPECT_EQ(again.Json({"where", "laptop"})["objects"].size(), 0u);
  EXPECT_EQ(again.Json({"where", "book"})["objects"].size(), 1u);
  EXPECT_EQ(server.Stop(SIGTERM), 0);
}

// The teddy's true position in the map frame (the first camera's): the median of the 3D points
// of the first frame's depth inside the crop the teddy was registered from, nearer than 1.3 m
// (the teddy's front; the wall behind it is 6 m away). The detections lie on the same front.
Eigen::Vector3d TeddyTruth(const std::string& teddy) {
  const std::vector<std::string> depth_lines = testing::DataLines(teddy + "/depth.txt");
  const std::string first = depth_lines.front().substr(depth_lines.front().find(' ') + 1);
  const cv::Mat depth = cv::imread(teddy + "/" + first, cv::IMREAD_UNCHANGED);
  EXPECT_EQ(depth.type(), CV_16UC1);
  const double fx = 535.4, fy = 539.2, cx = 320.1, cy = 247.6;  // camera.yaml
  std::vector<double> xs, ys, zs;
  for (int v = 0; v < 360; ++v) {
    for (int u = 205; u < 478; ++u) {
      const double z = depth.at<uint16_t>(v, u) / 5000.0;
      if (z <= 0 || z >= 1.3) continue;
      xs.push_back((u - cx) / fx * z);
      ys.push_back((v - cy) / fy * z);
      zs.push_back(z);
    }
  }
  const auto median = [](std::vector<double>& v) {
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  return {median(xs), median(ys), median(zs)};
}

TEST(ObjectsE2ETest, TeddyIsFoundOnceNearItsTruePositionAndNotInTheCafe) {
  const std::string data = testing::SharedDataDir();
  if (data.empty())
    GTEST_SKIP() << "shared data not found (../shared/data): skipping teddy objects";
  const std::string teddy = data + "/tum_fr3_teddy_200";
  const std::string photo = std::string(SEMMAP_SOURCE_DIR) + "/data/samples/objects/teddy.png";
  testing::TempDir dir;
  testing::ServerProcess server;
  ASSERT_TRUE(server.Start(dir.File("data")).ok());
  const Cli cli{server.address()};
  ASSERT_FALSE(cli.Json({"objects", "add", "teddy", photo}).is_null());
  ASSERT_FALSE(cli.Json({"ingest", teddy, "--map", "teddy"}).is_null());
  const nlohmann::json found = cli.Json({"where", "teddy", "--map", "teddy"});
  ASSERT_FALSE(found.is_null());
  ASSERT_EQ(found["objects"].size(), 1u) << found.dump();
  const Eigen::Vector3d truth = TeddyTruth(teddy);
  const Eigen::Vector3d p = Position(found["objects"][0]);
  std::printf("teddy: found at (%.3f %.3f %.3f), truth (%.3f %.3f %.3f): %.3f m off, %d views\n",
              p.x(), p.y(), p.z(), truth.x(), truth.y(), truth.z(), (p - truth).norm(),
              found["objects"][0]["observations"].get<int>());
  EXPECT_LT((p - truth).norm(), 0.10);

  // KNOWN_POSES (the ground truth as poses): the server extracts features itself, and the
  // teddy lands at the truth moved into the mocap frame by the first frame's pose (the client
  // takes the first ground-truth pose for it: it lies 0.15 s after the frame).
  ASSERT_FALSE(
      cli.Json({"ingest", teddy, "--map", "mocap", "--poses", "groundtruth.txt"}).is_null());
  const nlohmann::json in_mocap = cli.Json({"where", "teddy", "--map", "mocap"});
  ASSERT_FALSE(in_mocap.is_null());
  ASSERT_EQ(in_mocap["objects"].size(), 1u) << in_mocap.dump();
  StatusOr<std::vector<StampedPose>> gt = ReadTumTrajectory(teddy + "/groundtruth.txt");
  ASSERT_TRUE(gt.ok());
  const Eigen::Vector3d truth_mocap = gt->front().T_world_camera * truth;
  const Eigen::Vector3d p_mocap = Position(in_mocap["objects"][0]);
  std::printf("teddy with ground-truth poses: %.3f m off\n", (p_mocap - truth_mocap).norm());
  EXPECT_LT((p_mocap - truth_mocap).norm(), 0.10);

  const std::string cafe = data + "/kinect_cafe_391_nogt";
  ASSERT_FALSE(cli.Json({"ingest", cafe, "--map", "cafe"}).is_null());
  const nlohmann::json in_cafe = cli.Json({"where", "teddy", "--map", "cafe"});
  ASSERT_FALSE(in_cafe.is_null());
  EXPECT_EQ(in_cafe["objects"].size(), 0u) << in_cafe.dump();
  EXPECT_EQ(server.Stop(SIGTERM), 0);
}

}  // namespace
}  // namespace semmap
