// semmapd killed with SIGKILL mid-ingest, again and again: the database must stay intact and
// every frame the server acknowledged as durable must be there after reopening.
#include <gtest/gtest.h>

#include <atomic>
#include <csignal>
#include <random>
#include <thread>

#include "client/lib/map_client.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "tests/integration/ingest_test_util.h"
#include "tests/testing/server_process.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

TEST(Kill9Test, AcknowledgedDurableFramesSurvive) {
  testing::TempDir dir;
  std::mt19937 rng(1234);
  std::uniform_int_distribution<int> kill_after_ms(150, 900);
  constexpr int kRounds = 6;
  int rounds_with_durable_frames = 0;

  for (int round = 0; round < kRounds; ++round) {
    const std::string session = "round" + std::to_string(round);
    testing::ServerProcess server;
    ASSERT_TRUE(server.Start(dir.path()).ok()) << "round " << round;
    ClientOptions options;
    options.server = server.address();
    MapClient client(options);
    auto stream = client.Ingest(testing::KnownPosesStart("crash", session, 320, 240));
    ASSERT_TRUE(stream.ok()) << stream.status().ToString();

    std::thread writer([&] {
      const auto poses = testing::CircleTrajectory(2000, 3.0);
      for (int i = 0; i < 2000; ++i) {
        if (!(*stream)->Write(testing::MakeFrame(i, poses[i], 320, 240)).ok()) return;
      }
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(kill_after_ms(rng)));
    EXPECT_EQ(server.Stop(SIGKILL), 128 + SIGKILL);
    writer.join();
    const std::optional<uint64_t> durable = (*stream)->durable_seq();
    stream->reset();

    auto store = SqliteMapStore::Open(dir.path() + "/semmap.db", SqliteOptions{});
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    ASSERT_TRUE((*store)->IntegrityCheck().ok()) << "round " << round;
    if (!durable) continue;  // killed before the first commit was acknowledged
    ++rounds_with_durable_frames;
    auto info = (*store)->GetSession("crash", session);
    ASSERT_TRUE(info.ok()) << info.status().ToString();
    auto trajectory = (*store)->GetTrajectory(info->id, false);
    ASSERT_TRUE(trajectory.ok());
    ASSERT_GE(trajectory->size(), *durable + 1) << "round " << round;
    for (uint64_t seq = 0; seq <= *durable; ++seq) {
      ASSERT_EQ((*trajectory)[seq].seq, static_cast<int64_t>(seq)) << "round " << round;
    }
  }
  EXPECT_GE(rounds_with_durable_frames, kRounds / 2) << "kills came too early to test much";

  // A clean server still opens the database and lists every round that got started.
  testing::ServerProcess server;
  ASSERT_TRUE(server.Start(dir.path()).ok());
  ClientOptions options;
  options.server = server.address();
  MapClient client(options);
  auto sessions = client.ListSessions("crash");
  ASSERT_TRUE(sessions.ok()) << sessions.status().ToString();
  EXPECT_EQ(sessions->size(), static_cast<size_t>(kRounds));
  // Each was killed mid-stream: the next start found it open and says so.
  for (const SessionInfo& s : *sessions) {
    EXPECT_EQ(s.end_reason, SessionEndReason::kCrashed) << s.name;
    EXPECT_EQ(s.ended_unix_ns, 0) << s.name;
  }
  EXPECT_EQ(server.Stop(SIGTERM), 0);
}

}  // namespace
}  // namespace semmap
