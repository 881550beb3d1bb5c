// A slow consumer must make the client's writes block, not grow the server's buffers: with the
// storage writer held, the number of frames the client manages to send levels off at about
// the pipeline's queue capacities, and everything completes once the writer is released.
#include <gtest/gtest.h>

#include <atomic>
#include <future>

#include "server/semmap_server.h"
#include "tests/integration/ingest_test_util.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

TEST(BackpressureTest, SlowStorageBlocksTheClient) {
  testing::TempDir dir;
  ServerOptions options;
  options.listen = "127.0.0.1:0";
  options.data_dir = dir.path();
  options.ingest.queue_capacity = 4;
  options.storage_queue_capacity = 4;
  auto server = SemmapServer::Start(options);
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  ClientOptions client_options;
  client_options.server = (*server)->address();
  MapClient client(client_options);

  constexpr int kWidth = 640, kHeight = 480, kFrames = 200;
  auto stream = client.Ingest(testing::KnownPosesStart("bp", "s", kWidth, kHeight));
  ASSERT_TRUE(stream.ok()) << stream.status().ToString();

  // Hold the storage writer until released.
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::promise<void> holding;
  std::thread holder([&] {
    Status s = (*server)->writer_for_testing().RunSync([&](MapStore&) {
      holding.set_value();
      released.wait();
      return OkStatus();
    });
    EXPECT_TRUE(s.ok());
  });
  holding.get_future().wait();

  // Raw 640x480 BGR frames (~0.9 MB each), sent from another thread.
  std::atomic<int> written{0};
  std::thread writer([&] {
    const auto poses = testing::CircleTrajectory(kFrames);
    for (int i = 0; i < kFrames; ++i) {
      v1::Frame frame = testing::MakeFrame(i, poses[i], kWidth, kHeight);
      const cv::Mat bgr = testing::TexturedImage(kWidth, kHeight, i);
      v1::RawImage* raw = frame.mutable_colour()->mutable_raw();
      raw->set_width(kWidth);
      raw->set_height(kHeight);
      raw->set_encoding("bgr8");
      raw->set_step(kWidth * 3);
      raw->set_data(std::string(reinterpret_cast<const char*>(bgr.data), bgr.total() * 3));
      if (!(*stream)->Write(std::move(frame)).ok()) return;
      written.fetch_add(1);
    }
  });

  // Wait until the count levels off (no progress for a second): the queues fill in about a
  // second in a release build, several under ThreadSanitizer.
  int before = -1;
  int now = written.load();
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (now != before && std::chrono::steady_clock::now() < give_up) {
    before = now;
    std::this_thread::sleep_for(std::chrono::seconds(1));
    now = written.load();
  }
  // Stalled, and far fewer than all frames in flight. What is in flight is bounded by the
  // session queue (4), the writer queue (4), the frame being processed and the transport's
  // flow-control windows (a few MB). A client that never blocks writes all 200.
  EXPECT_EQ(before, now) << "client writes never levelled off";
  EXPECT_LT(now, 40) << "client writes did not block";

  release.set_value();
  holder.join();
  writer.join();
  EXPECT_EQ(written.load(), kFrames);
  auto summary = (*stream)->Finish();
  ASSERT_TRUE(summary.ok()) << summary.status().ToString();
  EXPECT_EQ(summary->frames(), static_cast<uint64_t>(kFrames));
}

}  // namespace
}  // namespace semmap
