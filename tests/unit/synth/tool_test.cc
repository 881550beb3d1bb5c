// The semmap-synth command line: help, argument errors, a small noisy run.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

#include "client/datasets/dataset.h"
#include "tests/testing/synth/dataset_files.h"
#include "tests/testing/temp_dir.h"

namespace semmap::synth {
namespace {

using semmap::testing::TempDir;

const std::string kTool = std::string(SEMMAP_BINARY_DIR) + "/tools/semmap-synth";

// Runs the tool with `args` (shell words), capturing stdout and stderr; returns the exit code.
int RunTool(const std::string& args, std::string* output) {
  const std::string command = kTool + " " + args + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return -1;
  std::array<char, 4096> buffer{};
  output->clear();
  for (size_t n; (n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0;) {
    output->append(buffer.data(), n);
  }
  const int status = ::pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

class ToolTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(kTool)) GTEST_SKIP() << kTool << " is not built";
  }
  TempDir tmp_;
  std::string out_;
};

TEST_F(ToolTest, HelpListsTheOptions) {
  EXPECT_EQ(RunTool("--help", &out_), 0);
  for (const char* flag : {"--trajectory", "--frames", "--seed", "--width", "--fx", "--depth-noise",
                           "--colour-noise", "--blur", "--drop-depth"}) {
    EXPECT_NE(out_.find(flag), std::string::npos) << flag;
  }
}

TEST_F(ToolTest, BadArgumentsAreUsageErrors) {
  const std::string dir = tmp_.File("x");
  const std::pair<std::string, std::string> cases[] = {
      {"", "missing OUT_DIR"},
      {dir + " --trajectory spiral", "unknown trajectory 'spiral'"},
      {dir + " --frames 0", "--frames must be in 1..1000000"},
      {dir + " --frames ten", "--frames expects an integer"},
      {dir + " --drop-depth 2", "drop-depth probability must be in [0, 1]"},
      {dir + " --fx -5", "camera"},
      {dir + " --bogus", "unknown option"},
      {dir + " other", "expected one OUT_DIR"},
  };
  for (const auto& [args, message] : cases) {
    EXPECT_EQ(RunTool(args, &out_), 2) << args;
    EXPECT_NE(out_.find(message), std::string::npos) << args << "\n" << out_;
    EXPECT_NE(out_.find("usage: semmap-synth"), std::string::npos);
  }
  EXPECT_FALSE(std::filesystem::exists(dir));
}

TEST_F(ToolTest, WritesANoisySequenceThatOpens) {
  const std::string dir = tmp_.File("seq");
  ASSERT_EQ(RunTool(dir + " --trajectory fast --frames 4 --width 160 --height 120 --seed 3"
                          " --depth-noise --colour-noise --blur --drop-depth 0.1",
                    &out_),
            0)
      << out_;
  EXPECT_NE(out_.find("4/4 frames"), std::string::npos) << out_;  // progress
  EXPECT_NE(out_.find("wrote 4 frames (fast, 160x120, seed 3)"), std::string::npos) << out_;
  StatusOr<Dataset> dataset = OpenDataset(dir);
  ASSERT_TRUE(dataset.ok()) << dataset.status().ToString();
  EXPECT_EQ(dataset->frames.size(), 4u);
  EXPECT_EQ(dataset->camera.width, 160);
  EXPECT_DOUBLE_EQ(dataset->camera.fx, 131.25);
  EXPECT_EQ(dataset->ground_truth.size(), 4u);
  EXPECT_TRUE(ReadObjectsFile(dir + "/objects.txt").ok());
  // A second run into the same (now non-empty) directory fails without touching it.
  EXPECT_EQ(RunTool(dir + " --frames 2 --quiet", &out_), 1);
  EXPECT_NE(out_.find("not empty"), std::string::npos) << out_;
}

}  // namespace
}  // namespace semmap::synth
