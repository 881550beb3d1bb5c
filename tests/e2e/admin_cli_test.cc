// semmap sessions remove / maps remove against a real semmapd: nothing is removed without
// confirmation, what is confirmed is gone, and the rest of the map keeps working.
#include <gtest/gtest.h>

#include <csignal>
#include <string>
#include <vector>

#include "client/lib/map_client.h"
#include "tests/integration/ingest_test_util.h"
#include "tests/testing/server_process.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

using testing::RunCommand;
using testing::SemmapCliPath;

// Runs the CLI with stdin from /dev/null (not a terminal) and returns its exit code.
int Cli(const std::string& server, const std::vector<std::string>& args, std::string* out) {
  std::string command = SemmapCliPath() + " --server " + server;
  for (const std::string& a : args) command += " '" + a + "'";
  return RunCommand({"/bin/sh", "-c", command + " < /dev/null 2>&1"}, out);
}

TEST(AdminCliTest, RemovalsNeedConfirmationAndTakeOnlyWhatTheyName) {
  testing::TempDir dir;
  testing::ServerProcess server;
  ASSERT_TRUE(server.Start(dir.path()).ok());
  ClientOptions options;
  options.server = server.address();
  MapClient client(options);
  for (const char* session : {"first", "second"}) {
    auto stream = client.Ingest(testing::KnownPosesStart("home", session));
    ASSERT_TRUE(stream.ok()) << stream.status().ToString();
    const auto poses = testing::CircleTrajectory(5);
    for (int i = 0; i < 5; ++i) ASSERT_TRUE((*stream)->Write(testing::MakeFrame(i, poses[i])).ok());
    ASSERT_TRUE((*stream)->Finish().ok());
  }

  std::string out;
  EXPECT_EQ(Cli(server.address(), {"sessions", "remove", "--map", "home", "first"}, &out), 2);
  EXPECT_NE(out.find("stdin is not a terminal; pass --yes"), std::string::npos) << out;
  EXPECT_EQ(client.ListSessions("home")->size(), 2u);

  out.clear();
  EXPECT_EQ(Cli(server.address(), {"sessions", "remove", "--map", "home", "nope", "--yes"}, &out),
            1);
  EXPECT_NE(out.find("NOT_FOUND"), std::string::npos) << out;

  out.clear();
  ASSERT_EQ(Cli(server.address(), {"sessions", "remove", "--map", "home", "first", "--yes"}, &out),
            0)
      << out;
  EXPECT_NE(out.find("removed session 'first' of map 'home': 5 frames, 5 keyframes"),
            std::string::npos)
      << out;
  auto left = client.ListSessions("home");
  ASSERT_TRUE(left.ok());
  ASSERT_EQ(left->size(), 1u);
  EXPECT_EQ((*left)[0].name, "second");

  out.clear();
  ASSERT_EQ(Cli(server.address(), {"sessions", "--map", "home"}, &out), 0);
  EXPECT_NE(out.find("completed"), std::string::npos) << out;

  out.clear();
  EXPECT_EQ(Cli(server.address(), {"maps", "remove", "home"}, &out), 2);
  out.clear();
  ASSERT_EQ(Cli(server.address(), {"--json", "maps", "remove", "home", "--yes"}, &out), 0) << out;
  EXPECT_NE(out.find("\"sessions\":1"), std::string::npos) << out;
  EXPECT_TRUE(client.ListMaps()->empty());
  EXPECT_EQ(server.Stop(SIGTERM), 0);
}

}  // namespace
}  // namespace semmap
