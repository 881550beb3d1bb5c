// MONO sessions end to end through semmapd and the semmap CLI with the shipped VO model: a
// synthetic tour streamed colour-only is acknowledged frame by frame, stored with keyframes,
// lands near the true trajectory without any scale alignment, and the objects it passes are
// placed from the network's depth. A server whose model is missing or damaged says so and
// refuses MONO with FAILED_PRECONDITION while RGBD keeps working, and `semmapd
// --check-vo-model` says so too.
#include <gtest/gtest.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "client/datasets/trajectory_io.h"
#include "tests/testing/server_process.h"
#include "tests/testing/temp_dir.h"
#include "tests/testing/text_lines.h"

namespace semmap {
namespace {

using testing::RunCommand;
using testing::SemmapCliPath;

const std::string kModel = std::string(SEMMAP_SOURCE_DIR) + "/models/vo/semmap_vo.onnx";

nlohmann::json Json(const std::string& server, std::vector<std::string> args) {
  std::vector<std::string> argv = {SemmapCliPath(), "--server", server, "--json"};
  argv.insert(argv.end(), args.begin(), args.end());
  std::string out;
  if (RunCommand(argv, &out) != 0) return nullptr;
  return nlohmann::json::parse(out, nullptr, /*allow_exceptions=*/false);
}

void Synth(const std::string& path, const std::string& kind, int frames) {
  std::string out;
  ASSERT_EQ(RunCommand({std::string(SEMMAP_BINARY_DIR) + "/tools/semmap-synth", path,
                        "--trajectory", kind, "--frames", std::to_string(frames), "--seed", "31",
                        "--depth-noise", "--colour-noise", "--quiet"},
                       &out),
            0)
      << out;
}

TEST(MonoE2ETest, ASyntheticTourIsTrackedMetricallyAndItsObjectsPlaced) {
  if (!std::filesystem::exists(kModel)) GTEST_SKIP() << "no trained VO model at " << kModel;
  std::string check;
  ASSERT_EQ(RunCommand({testing::SemmapdPath(), "--check-vo-model", kModel}, &check), 0);
  EXPECT_NE(check.find(" OK: input "), std::string::npos) << check;
  testing::TempDir dir;
  const std::string seq = dir.File("tour");
  Synth(seq, "tour", 240);
  testing::ServerProcess server;
  ASSERT_TRUE(server.Start(dir.File("data")).ok());
  for (const char* label : {"book", "laptop", "mug_poster", "teddy_box"}) {
    ASSERT_FALSE(
        Json(server.address(), {"objects", "add", label, seq + "/objects/" + label + ".png"})
            .is_null());
  }
  const std::string est = dir.File("est.txt");
  const nlohmann::json ingest = Json(
      server.address(),
      {"ingest", seq, "--map", "mono", "--mono", "--session", "tour", "--trajectory-out", est});
  ASSERT_FALSE(ingest.is_null());
  EXPECT_EQ(ingest["frames_stored"], 240);  // every frame acknowledged with a pose and stored
  EXPECT_EQ(ingest["lost_frames"], 0);
  EXPECT_GT(ingest["keyframes"].get<int>(), 5);
  const nlohmann::json sessions = Json(server.address(), {"sessions", "--map", "mono"});
  ASSERT_FALSE(sessions.is_null());
  EXPECT_EQ(sessions["sessions"][0]["mode"], "mono") << sessions.dump();

  // ATE with a rigid alignment only: the scale is the network's.
  const nlohmann::json ate = Json(server.address(), {"eval", "ate", seq + "/groundtruth.txt", est});
  ASSERT_FALSE(ate.is_null());
  const nlohmann::json scaled =
      Json(server.address(), {"eval", "ate", seq + "/groundtruth.txt", est, "--scale"});
  std::printf("MONO tour: ATE %.3f m without scale alignment, scale %.3f\n",
              ate["rmse"].get<double>(), scaled["scale"].get<double>());
  EXPECT_LT(ate["rmse"].get<double>(), 0.15);
  EXPECT_NEAR(scaled["scale"].get<double>(), 1.0, 0.2);

  // Objects placed from predicted depth: the tour stops 1 m in front of each.
  const nlohmann::json where = Json(server.address(), {"where", "--map", "mono"});
  ASSERT_FALSE(where.is_null());
  std::printf("MONO tour: %zu objects placed\n", where["objects"].size());
  EXPECT_GE(where["objects"].size(), 2u) << where.dump();
  EXPECT_EQ(server.Stop(SIGTERM), 0);
}

TEST(MonoE2ETest, AMissingOrDamagedModelRefusesMonoAndRgbdKeepsWorking) {
  testing::TempDir dir;
  const std::string seq = dir.File("circle");
  Synth(seq, "circle", 20);
  {
    std::ofstream(dir.File("bad.onnx")) << "not a network";
    std::ofstream(dir.File("bad.json")) << "{}";
  }
  for (const std::string& model : {dir.File("missing.onnx"), dir.File("bad.onnx")}) {
    testing::ServerProcess server;
    ASSERT_TRUE(server
                    .Start(dir.File("data-" + std::filesystem::path(model).stem().string()),
                           {"--vo-model", model})
                    .ok());
    // The CLI's error goes to stderr: read it through a shell.
    std::string text;
    const int rc = RunCommand({"/bin/sh", "-c",
                               SemmapCliPath() + " --server " + server.address() + " ingest " +
                                   seq + " --map m --mono 2>&1"},
                              &text);
    EXPECT_EQ(rc, 1);
    EXPECT_NE(text.find("FAILED_PRECONDITION"), std::string::npos) << text;
    EXPECT_NE(text.find("VO model"), std::string::npos) << text;
    const nlohmann::json rgbd = Json(server.address(), {"ingest", seq, "--map", "m"});
    ASSERT_FALSE(rgbd.is_null()) << model;
    EXPECT_EQ(rgbd["frames_stored"], 20);
    EXPECT_EQ(server.Stop(SIGTERM), 0);
    // The operator's check before deploying says the same without starting a server.
    std::string check;
    EXPECT_EQ(RunCommand({"/bin/sh", "-c",
                          testing::SemmapdPath() + " --check-vo-model " + model + " 2>&1"},
                         &check),
              1);
    EXPECT_NE(check.find("VO model not usable"), std::string::npos) << check;
  }
}

}  // namespace
}  // namespace semmap
