// RGBD visual SLAM end to end: a synthetic lap of the default room (known trajectory) streamed
// by the semmap CLI into semmapd in RGBD mode. Every frame is tracked, the back end closes the
// loop (a loop link is stored), and the stored trajectory's ATE is within a tight bound. With
// the shared data present, the real TUM fr3/teddy sequence is tracked on every frame too.
#include <gtest/gtest.h>
#include <signal.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "client/datasets/trajectory_io.h"
#include "client/eval/ate.h"
#include "tests/testing/server_process.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

using testing::RunCommand;
using testing::SemmapCliPath;

std::string SynthPath() { return std::string(SEMMAP_BINARY_DIR) + "/tools/semmap-synth"; }

double StoredAte(const std::string& gt_path, const std::string& est_path) {
  StatusOr<std::vector<StampedPose>> gt = ReadTumTrajectory(gt_path);
  StatusOr<std::vector<StampedPose>> est = ReadTumTrajectory(est_path);
  EXPECT_TRUE(gt.ok() && est.ok());
  if (!gt.ok() || !est.ok()) return 1e9;
  StatusOr<AteResult> ate = ComputeAte(*gt, *est);
  EXPECT_TRUE(ate.ok()) << ate.status().ToString();
  return ate.ok() ? ate->stats.rmse : 1e9;
}

TEST(RgbdSlamE2ETest, SyntheticLapIsTrackedAndItsLoopClosed) {
  testing::TempDir dir;
  const std::string seq = dir.File("lap");
  std::string out;
  ASSERT_EQ(RunCommand({SynthPath(), seq, "--trajectory", "circle", "--frames", "300",
                        "--depth-noise", "--colour-noise", "--quiet"},
                       &out),
            0)
      << out;

  testing::ServerProcess server;
  ASSERT_TRUE(server.Start(dir.File("data")).ok());
  const std::string est = dir.File("est.txt");
  out.clear();
  ASSERT_EQ(RunCommand({SemmapCliPath(), "--server", server.address(), "--json", "ingest", seq,
                        "--map", "lap", "--session", "rgbd", "--trajectory-out", est},
                       &out),
            0)
      << out;
  const auto ingest = nlohmann::json::parse(out);
  EXPECT_EQ(ingest["frames_stored"], 300);
  EXPECT_EQ(ingest["lost_frames"], 0);
  EXPECT_GE(ingest["loop_closures"].get<int>(), 1);

  const double rmse = StoredAte(seq + "/groundtruth.txt", est);
  std::printf("synthetic lap (300 frames, RGBD through semmapd): ATE RMSE %.4f m, %d loops\n", rmse,
              ingest["loop_closures"].get<int>());
  EXPECT_LT(rmse, 0.01);

  // The loop closure is in the stored links.
  out.clear();
  const std::string exported = dir.File("lap.json");
  ASSERT_EQ(RunCommand({SemmapCliPath(), "--server", server.address(), "--json", "export", "--map",
                        "lap", "--format", "json", "-o", exported},
                       &out),
            0)
      << out;
  std::ifstream file(exported);
  const auto doc = nlohmann::json::parse(file);
  int loops = 0;
  for (const auto& link : doc["links"]) loops += link["kind"] == "loop";
  EXPECT_GE(loops, 1);
  EXPECT_EQ(server.Stop(SIGTERM), 0);
}

TEST(RgbdSlamE2ETest, TeddyIsTrackedOnEveryFrame) {
  const std::string data = testing::SharedDataDir();
  if (data.empty()) GTEST_SKIP() << "shared data not found (../shared/data): skipping teddy RGBD";
  const std::string teddy = data + "/tum_fr3_teddy_200";
  testing::TempDir dir;
  testing::ServerProcess server;
  ASSERT_TRUE(server.Start(dir.File("data")).ok());
  const std::string est = dir.File("est.txt");
  std::string out;
  ASSERT_EQ(RunCommand({SemmapCliPath(), "--server", server.address(), "--json", "ingest", teddy,
                        "--map", "teddy", "--trajectory-out", est},
                       &out),
            0)
      << out;
  const auto ingest = nlohmann::json::parse(out);
  EXPECT_EQ(ingest["frames_stored"], 200);
  EXPECT_EQ(ingest["lost_frames"], 0);
  const double rmse = StoredAte(teddy + "/groundtruth.txt", est);
  std::printf("tum_fr3_teddy_200 (RGBD through semmapd): ATE RMSE %.4f m\n", rmse);
  // The accuracy figure is the bench's to report; this bound catches a broken pipeline.
  EXPECT_LT(rmse, 0.02);
  EXPECT_EQ(server.Stop(SIGTERM), 0);
}

}  // namespace
}  // namespace semmap
