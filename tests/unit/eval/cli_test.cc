// Runs the built `semmap eval` on temporary files and checks its exit codes and --json output.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "client/eval/ate.h"
#include "tests/testing/temp_dir.h"
#include "tests/unit/eval/eval_test_util.h"

namespace semmap {
namespace {

struct CliRun {
  int exit_code = -1;
  std::string out;  // stdout only
};

class EvalCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    binary_ = std::string(SEMMAP_BINARY_DIR) + "/client/cli/semmap";
    if (!std::filesystem::exists(binary_)) {
      GTEST_SKIP() << binary_ << " is not built (SEMMAP_BUILD_SERVICE=OFF?)";
    }
    gt_ = eval_test::Helix(120);
    est_ = eval_test::Transformed(gt_, eval_test::Rot(0.3, {1, 0, 1}), {0.1, 0.2, 0.3}, 0.7);
    for (size_t i = 0; i < est_.size(); i += 2) est_[i].T_world_camera.translation().x() += 0.01;
    ASSERT_TRUE(WriteTumTrajectory(dir_.File("gt.txt"), gt_).ok());
    ASSERT_TRUE(WriteTumTrajectory(dir_.File("est.txt"), est_).ok());
  }

  CliRun Semmap(const std::string& args) {
    CliRun run;
    const std::string command = binary_ + " " + args + " 2>" + dir_.File("stderr.txt");
    FILE* pipe = ::popen(command.c_str(), "r");
    if (pipe == nullptr) return run;
    char buffer[4096];
    size_t n;
    while ((n = std::fread(buffer, 1, sizeof(buffer), pipe)) > 0) run.out.append(buffer, n);
    const int status = ::pclose(pipe);
    run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return run;
  }

  std::string Files() { return dir_.File("gt.txt") + " " + dir_.File("est.txt"); }

  std::string binary_;
  testing::TempDir dir_;
  std::vector<StampedPose> gt_, est_;
};

TEST_F(EvalCliTest, AteJsonMatchesTheLibrary) {
  const CliRun run = Semmap("eval ate " + Files() + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.out;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  // What the CLI read back from the files, evaluated in-process.
  const AteResult expected = ComputeAte(ReadTumTrajectory(dir_.File("gt.txt")).value(),
                                        ReadTumTrajectory(dir_.File("est.txt")).value())
                                 .value();
  EXPECT_EQ(j.at("pairs").get<size_t>(), 120u);
  EXPECT_DOUBLE_EQ(j.at("rmse").get<double>(), expected.stats.rmse);
  EXPECT_DOUBLE_EQ(j.at("mean").get<double>(), expected.stats.mean);
  EXPECT_DOUBLE_EQ(j.at("median").get<double>(), expected.stats.median);
  EXPECT_DOUBLE_EQ(j.at("std").get<double>(), expected.stats.std);
  EXPECT_DOUBLE_EQ(j.at("min").get<double>(), expected.stats.min);
  EXPECT_DOUBLE_EQ(j.at("max").get<double>(), expected.stats.max);
  EXPECT_FALSE(j.contains("scale"));
  EXPECT_GT(expected.stats.rmse, 0.05);  // the 0.7 scale is not aligned away
}

TEST_F(EvalCliTest, AteWithScaleReportsTheScaleAndDrawsFigures) {
  const CliRun run = Semmap("eval ate " + Files() + " --scale --json --plot " + dir_.File("t.png") +
                            " --plot-errors " + dir_.File("e.png"));
  ASSERT_EQ(run.exit_code, 0) << run.out;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_NEAR(j.at("scale").get<double>(), 1 / 0.7, 1e-3);
  EXPECT_LT(j.at("rmse").get<double>(), 0.01);
  EXPECT_GT(std::filesystem::file_size(dir_.File("t.png")), 1000u);
  EXPECT_GT(std::filesystem::file_size(dir_.File("e.png")), 1000u);
}

TEST_F(EvalCliTest, AteTextUsesTheTumScriptLines) {
  const CliRun run = Semmap("eval ate " + Files() + " --scale");
  ASSERT_EQ(run.exit_code, 0);
  EXPECT_NE(run.out.find("compared_pose_pairs 120 pairs\n"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("absolute_translational_error.rmse "), std::string::npos);
  EXPECT_NE(run.out.find("alignment.scale 1.4"), std::string::npos);
}

TEST_F(EvalCliTest, RpeJson) {
  const CliRun run = Semmap("eval rpe " + Files() + " --delta 10 --delta-unit f --json");
  ASSERT_EQ(run.exit_code, 0) << run.out;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j.at("pairs").get<size_t>(), 109u);  // i = 0..108 pairs with i + 10 < 119
  EXPECT_GT(j.at("translation_m").at("rmse").get<double>(), 0);
  EXPECT_TRUE(j.at("rotation_deg").contains("median"));
}

TEST_F(EvalCliTest, KittiJson) {
  std::vector<StampedPose> gt, est;
  for (int i = 0; i < 300; ++i) {
    gt.push_back(eval_test::MakePose(i, {0, 0, 1.0 * i}));
    est.push_back(eval_test::MakePose(i, {0, 0, 1.02 * i}));
  }
  ASSERT_TRUE(WriteKittiPoses(dir_.File("gt.kitti"), gt).ok());
  ASSERT_TRUE(WriteKittiPoses(dir_.File("est.kitti"), est).ok());
  const CliRun run =
      Semmap("eval kitti " + dir_.File("gt.kitti") + " " + dir_.File("est.kitti") + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.out;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_NEAR(j.at("t_rel").get<double>(), 2.0, 0.03);
  EXPECT_EQ(j.at("lengths").size(), 2u);  // 100 m and 200 m fit in 299 m
  // Different pose counts: an error, not a crash.
  est.pop_back();
  ASSERT_TRUE(WriteKittiPoses(dir_.File("est.kitti"), est).ok());
  EXPECT_EQ(Semmap("eval kitti " + dir_.File("gt.kitti") + " " + dir_.File("est.kitti")).exit_code,
            1);
}

TEST_F(EvalCliTest, UsageAndDataErrors) {
  EXPECT_EQ(Semmap("eval").exit_code, 2);
  EXPECT_EQ(Semmap("eval nonsense a b").exit_code, 2);
  EXPECT_EQ(Semmap("eval ate " + dir_.File("gt.txt")).exit_code, 2);
  EXPECT_EQ(Semmap("eval ate " + Files() + " --max-diff -1").exit_code, 2);
  EXPECT_EQ(Semmap("eval rpe " + Files() + " --delta-unit m").exit_code, 2);
  EXPECT_EQ(Semmap("eval ate " + Files() + " --bogus").exit_code, 2);
  EXPECT_EQ(Semmap("eval ate --help").exit_code, 0);
  EXPECT_EQ(Semmap("eval ate " + dir_.File("missing.txt") + " " + dir_.File("est.txt")).exit_code,
            1);
  // Far-apart stamps: no pairs, a clear error (exit 1), no output on stdout.
  std::vector<StampedPose> late = est_;
  for (StampedPose& p : late) p.stamp_ns += 3600 * eval_test::kSecond;
  ASSERT_TRUE(WriteTumTrajectory(dir_.File("late.txt"), late).ok());
  const CliRun run = Semmap("eval ate " + dir_.File("gt.txt") + " " + dir_.File("late.txt"));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_TRUE(run.out.empty());
}

}  // namespace
}  // namespace semmap
