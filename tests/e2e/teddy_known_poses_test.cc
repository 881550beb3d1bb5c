// The real TUM fr3/teddy sequence streamed by the semmap CLI into a semmapd process with its
// ground-truth poses; after a restart the session, all 200 poses and the keyframes are there.
#include <gtest/gtest.h>

#include <csignal>
#include <nlohmann/json.hpp>

#include "tests/testing/server_process.h"
#include "tests/testing/temp_dir.h"
#include "tests/testing/text_lines.h"

namespace semmap {
namespace {

using testing::RunCommand;
using testing::SemmapCliPath;

// Pose lines (not comments, not blank) of a TUM trajectory file.
size_t CountPoseLines(const std::string& path) { return testing::DataLines(path).size(); }

TEST(TeddyE2ETest, KnownPosesSessionSurvivesRestart) {
  const std::string data = testing::SharedDataDir();
  if (data.empty()) GTEST_SKIP() << "shared data not found (../shared/data): skipping teddy e2e";
  const std::string teddy = data + "/tum_fr3_teddy_200";
  testing::TempDir dir;

  testing::ServerProcess server;
  ASSERT_TRUE(server.Start(dir.path()).ok());
  std::string out;
  const std::string trajectory_file = dir.File("teddy_est.txt");
  ASSERT_EQ(RunCommand({SemmapCliPath(), "--server", server.address(), "--json", "ingest", teddy,
                        "--poses", "groundtruth.txt", "--map", "teddy", "--session", "gt",
                        "--trajectory-out", trajectory_file},
                       &out),
            0)
      << out;
  const auto ingest = nlohmann::json::parse(out);
  EXPECT_EQ(ingest["frames_stored"], 200);
  EXPECT_EQ(ingest["durable_seq"], 199);
  const int keyframes = ingest["keyframes"];
  EXPECT_GT(keyframes, 5);
  EXPECT_LT(keyframes, 200);

  // --trajectory-out has a pose for every streamed frame.
  EXPECT_EQ(CountPoseLines(trajectory_file), 200u);

  EXPECT_EQ(server.Stop(SIGTERM), 0);
  ASSERT_TRUE(server.Start(dir.path()).ok());

  out.clear();
  ASSERT_EQ(RunCommand({SemmapCliPath(), "--server", server.address(), "--json", "sessions",
                        "--map", "teddy"},
                       &out),
            0)
      << out;
  const auto sessions = nlohmann::json::parse(out)["sessions"];
  ASSERT_EQ(sessions.size(), 1u);
  EXPECT_EQ(sessions[0]["name"], "gt");
  EXPECT_EQ(sessions[0]["frames"], 200);
  EXPECT_EQ(sessions[0]["keyframes"], keyframes);
  EXPECT_FALSE(sessions[0]["ended"].is_null());

  out.clear();
  ASSERT_EQ(RunCommand({SemmapCliPath(), "--server", server.address(), "--json", "trajectory",
                        "--map", "teddy", "--session", "gt"},
                       &out),
            0);
  const auto poses = nlohmann::json::parse(out)["poses"];
  ASSERT_EQ(poses.size(), 200u);
  int stored_keyframes = 0;
  for (const auto& p : poses) stored_keyframes += p["keyframe"].get<bool>();
  EXPECT_EQ(stored_keyframes, keyframes);
  EXPECT_EQ(poses[0]["stamp"], "1341841873.273798");

  // Export through the CLI: the file holds the full trajectory and the client checked its sha256.
  out.clear();
  const std::string exported = dir.File("teddy.tum");
  ASSERT_EQ(RunCommand({SemmapCliPath(), "--server", server.address(), "--json", "export", "--map",
                        "teddy", "--format", "tum", "-o", exported},
                       &out),
            0)
      << out;
  EXPECT_EQ(nlohmann::json::parse(out)["sha256"].get<std::string>().size(), 64u);
  EXPECT_EQ(CountPoseLines(exported), 200u);

  out.clear();
  EXPECT_EQ(RunCommand({SemmapCliPath(), "--server", server.address(), "trajectory", "--map",
                        "teddy", "--session", "missing"},
                       &out),
            1);
  EXPECT_EQ(server.Stop(SIGTERM), 0);
}

}  // namespace
}  // namespace semmap
