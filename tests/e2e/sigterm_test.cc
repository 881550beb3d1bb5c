// SIGTERM while a client is streaming: semmapd stops within 10 s with exit status 0, the stream
// ends (OK or UNAVAILABLE), everything acknowledged as durable is stored and the session is
// closed, and the database needs no recovery.
#include <gtest/gtest.h>

#include <atomic>
#include <csignal>
#include <thread>

#include "client/lib/map_client.h"
#include "storage/sqlite/sqlite_map_store.h"
#include "tests/integration/ingest_test_util.h"
#include "tests/testing/server_process.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

TEST(SigtermTest, MidIngestShutdownIsCleanAndQuick) {
  testing::TempDir dir;
  testing::ServerProcess server;
  ASSERT_TRUE(server.Start(dir.path()).ok());
  ClientOptions options;
  options.server = server.address();
  MapClient client(options);
  auto stream = client.Ingest(testing::KnownPosesStart("term", "s", 320, 240));
  ASSERT_TRUE(stream.ok()) << stream.status().ToString();

  std::atomic<bool> write_failed{false};
  std::thread writer([&] {
    const auto poses = testing::CircleTrajectory(100000, 3.0);
    for (int i = 0; i < 100000; ++i) {
      if (!(*stream)->Write(testing::MakeFrame(i, poses[i], 320, 240)).ok()) {
        write_failed = true;
        return;
      }
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(server.Stop(SIGTERM), 0);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(seconds, 10.0);
  writer.join();
  EXPECT_TRUE(write_failed.load());
  const Status final_status = (*stream)->Finish().status();
  EXPECT_EQ(final_status.code(), StatusCode::kUnavailable) << final_status.ToString();
  const std::optional<uint64_t> durable = (*stream)->durable_seq();
  ASSERT_TRUE(durable.has_value());
  stream->reset();

  auto store = SqliteMapStore::Open(dir.path() + "/semmap.db", SqliteOptions{});
  ASSERT_TRUE(store.ok());
  EXPECT_TRUE((*store)->IntegrityCheck().ok());
  auto session = (*store)->GetSession("term", "s");
  ASSERT_TRUE(session.ok());
  EXPECT_NE(session->ended_unix_ns, 0) << "a clean stop closes the session";
  EXPECT_GE(session->frame_count, static_cast<int64_t>(*durable + 1));
  std::cerr << "stopped in " << seconds << " s with " << session->frame_count
            << " frames stored (durable_seq " << *durable << ")\n";
}

}  // namespace
}  // namespace semmap
