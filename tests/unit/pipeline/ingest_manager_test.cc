// IngestManager over a real store: the limit on open maps, eviction of idle map pipelines
// (their state persisted and restored by the next session), sessions stopped by a shutdown.
#include "core/pipeline/ingest_manager.h"

#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <thread>
#include <vector>

#include "storage/sqlite/sqlite_map_store.h"
#include "tests/testing/synthetic_frames.h"
#include "tests/testing/temp_dir.h"
#include "tests/unit/pipeline/recording_sink.h"

namespace semmap {
namespace {

using testing::RecordingSink;

class IngestManagerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto store = SqliteMapStore::Open(dir_.File("db.sqlite"), SqliteOptions{});
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    auto writer = StorageWriter::Start(std::move(store).value(), StorageWriter::Options{});
    ASSERT_TRUE(writer.ok());
    writer_ = std::move(writer).value();
  }

  IngestOptions Options(size_t max_open, size_t max_idle) {
    IngestOptions options;
    options.max_open_maps = max_open;
    options.max_idle_maps = max_idle;
    options.open_reader = SqliteMapStore::Opener(dir_.File("db.sqlite"), {});
    return options;
  }

  struct Stream {
    std::shared_ptr<RecordingSink> sink = std::make_shared<RecordingSink>();
    std::shared_ptr<IngestSessionHandle> session;
  };

  // A KNOWN_POSES stream into `map` with frames 0..frames-1 (with depth: the layers build).
  Stream Open(IngestManager& manager, const std::string& map, int frames) {
    Stream s;
    StatusOr<std::shared_ptr<IngestSessionHandle>> opened = manager.Open(s.sink);
    EXPECT_TRUE(opened.ok()) << opened.status().ToString();
    if (!opened.ok()) return s;
    s.session = std::move(opened).value();
    IngestStartRequest start;
    start.map = map;
    start.mode = SessionMode::kKnownPoses;
    start.camera = testing::TestCamera(64, 48);
    Send(s, start);
    for (int i = 0; i < frames; ++i) Send(s, Frame(static_cast<uint64_t>(i), 0.2 * i));
    return s;
  }

  IngestFrame Frame(uint64_t seq, double x) {
    IngestFrame frame;
    frame.seq = seq;
    frame.stamp_ns = static_cast<int64_t>(seq + 1) * 1000;
    ImageMessage colour;
    colour.kind = ImageMessage::Kind::kCompressed;
    colour.encoding = "png";
    colour.data = testing::EncodePng(testing::TexturedImage(64, 48, 3));
    frame.colour = colour;
    DepthMessage depth;
    depth.image.kind = ImageMessage::Kind::kCompressed;
    depth.image.encoding = "png";
    depth.depth_scale = 5000;
    depth.image.data = testing::EncodePng(cv::Mat(48, 64, CV_16UC1, cv::Scalar(7500)));  // 1.5 m
    frame.depth = depth;
    PoseTq pose;
    pose.t.x() = x;
    frame.pose_prior = pose;
    return frame;
  }

  void Send(Stream& s, IngestMessage message) {
    while (!s.session->TryEnqueue(message)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }

  testing::TempDir dir_;
  std::unique_ptr<StorageWriter> writer_;
};

TEST_F(IngestManagerTest, OpenMapsAreLimitedAndIdleOnesAreEvictedThenRestored) {
  IngestManager manager(writer_.get(), Options(/*max_open=*/2, /*max_idle=*/1));
  Stream a = Open(manager, "a", 3);
  Stream b = Open(manager, "b", 3);
  ASSERT_TRUE(a.sink->WaitForAcks(3));
  ASSERT_TRUE(b.sink->WaitForAcks(3));
  EXPECT_EQ(manager.open_maps(), 2u);

  // A third map while both stream: refused, saying which limit.
  Stream c = Open(manager, "c", 1);
  const Status refused = c.sink->Wait();
  EXPECT_EQ(refused.code(), StatusCode::kResourceExhausted) << refused.ToString();
  EXPECT_NE(refused.message().find("--max-open-maps 2"), std::string::npos) << refused.ToString();
  EXPECT_EQ(manager.open_maps(), 2u);

  // "a" ends: its pipeline stays warm (max_idle 1) until a new map needs the room.
  Send(a, IngestEnd{});
  ASSERT_TRUE(a.sink->Wait().ok()) << a.sink->final_status->ToString();
  EXPECT_EQ(manager.open_maps(), 2u);
  Stream c2 = Open(manager, "c", 2);
  ASSERT_TRUE(c2.sink->WaitForAcks(2));
  {
    std::lock_guard lock(c2.sink->mutex);
    ASSERT_FALSE(c2.sink->final_status.has_value()) << c2.sink->final_status->ToString();
    EXPECT_EQ(c2.sink->acks.size(), 2u);
  }
  EXPECT_EQ(manager.open_maps(), 2u);  // "a" was released for "c"

  // Back on "a": restored from the store (its layers were persisted when it was released).
  Send(b, IngestEnd{});
  ASSERT_TRUE(b.sink->Wait().ok());
  Send(c2, IngestEnd{});
  ASSERT_TRUE(c2.sink->Wait().ok());
  Stream a2 = Open(manager, "a", 0);
  Send(a2, IngestEnd{});
  ASSERT_TRUE(a2.sink->Wait().ok()) << a2.sink->final_status->ToString();
  EXPECT_LE(manager.open_maps(), 2u);
  StatusOr<MapBlob> occupancy = MapBlob{};
  ASSERT_TRUE(writer_
                  ->RunSync([&](MapStore& store) -> Status {
                    SEMMAP_ASSIGN_OR_RETURN(MapInfo map, store.GetMap("a"));
                    occupancy = store.GetBlob(map.id, kOccupancyBlobKind);
                    return OkStatus();
                  })
                  .ok());
  EXPECT_TRUE(occupancy.ok()) << occupancy.status().ToString();  // its layers survived
}

TEST_F(IngestManagerTest, ShutdownStopsLiveSessionsAndReleasesEveryMap) {
  auto manager = std::make_unique<IngestManager>(writer_.get(), Options(4, 1));
  Stream a = Open(*manager, "a", 2);
  Stream b = Open(*manager, "b", 2);
  ASSERT_TRUE(a.sink->WaitForAcks(2));
  ASSERT_TRUE(b.sink->WaitForAcks(2));
  manager->BeginShutdown();
  EXPECT_EQ(a.sink->Wait().code(), StatusCode::kUnavailable);
  EXPECT_EQ(b.sink->Wait().code(), StatusCode::kUnavailable);
  manager->Join();
  EXPECT_EQ(manager->open_maps(), 0u);
  EXPECT_EQ(manager->active_sessions(), 0u);
  // Refused once shutting down.
  auto sink = std::make_shared<RecordingSink>();
  EXPECT_EQ(manager->Open(sink).status().code(), StatusCode::kUnavailable);
  a.session.reset();
  b.session.reset();
  manager.reset();  // joins nothing twice, leaks nothing (ASan/TSan runs)
}

// The manager alone owns sessions: its reaper destroys each once it has finished, and the
// transport's handle then does nothing (ASan / TSan runs check no use after free, no leak, no
// join on a session's own thread).
bool WaitUntilNoneOwned(IngestManager& manager) {
  for (int i = 0; i < 3000 && manager.owned_sessions() != 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return manager.owned_sessions() == 0;
}

TEST_F(IngestManagerTest, ACancelledSessionStoresWhatItHadAndIsReaped) {
  IngestManager manager(writer_.get(), Options(4, 1));
  Stream s = Open(manager, "a", 3);
  ASSERT_TRUE(s.sink->WaitForAcks(3));
  s.session->Cancel();
  EXPECT_EQ(s.sink->Wait().code(), StatusCode::kCancelled);
  EXPECT_EQ(s.sink->final_summary.frames, 3u);
  ASSERT_TRUE(WaitUntilNoneOwned(manager));
  // The handle outlives its session: every call is a no-op.
  IngestMessage late = IngestEnd{};
  EXPECT_FALSE(s.session->TryEnqueue(late));
  EXPECT_FALSE(s.session->HasRoom());
  s.session->Cancel();
  s.session->Stop();
}

TEST_F(IngestManagerTest, AVanishedClientsHandleCanBeDroppedMidStream) {
  IngestManager manager(writer_.get(), Options(4, 1));
  Stream s = Open(manager, "a", 2);
  ASSERT_TRUE(s.sink->WaitForAcks(2));
  // What the reactor does when the client disappears: cancel, then let go of the handle while
  // the session is still storing.
  s.session->Cancel(/*deadline_passed=*/true);
  s.session.reset();
  EXPECT_EQ(s.sink->Wait().code(), StatusCode::kDeadlineExceeded);
  EXPECT_TRUE(WaitUntilNoneOwned(manager));
  EXPECT_EQ(manager.active_sessions(), 0u);
}

TEST_F(IngestManagerTest, AServerStopMidSessionFinishesAndDestroysEverySession) {
  auto manager = std::make_unique<IngestManager>(writer_.get(), Options(4, 1));
  std::vector<Stream> streams;
  for (const char* map : {"a", "a", "b"}) streams.push_back(Open(*manager, map, 2));
  for (Stream& s : streams) ASSERT_TRUE(s.sink->WaitForAcks(2));
  manager->BeginShutdown();
  manager->Join();  // returns once every session finished and was destroyed
  EXPECT_EQ(manager->owned_sessions(), 0u);
  for (Stream& s : streams) {
    std::lock_guard lock(s.sink->mutex);
    ASSERT_TRUE(s.sink->final_status.has_value());
    EXPECT_EQ(s.sink->final_status->code(), StatusCode::kUnavailable);
    IngestMessage late = IngestEnd{};
    EXPECT_FALSE(s.session->TryEnqueue(late));
  }
  manager.reset();
}

TEST_F(IngestManagerTest, StreamsAreLimitedToMaxStreamsAndFinishedOnesFreeTheirPlace) {
  IngestOptions options = Options(4, 1);
  options.max_streams = 2;
  IngestManager manager(writer_.get(), options);
  Stream a = Open(manager, "a", 1);
  Stream b = Open(manager, "a", 1);
  auto refused = manager.Open(std::make_shared<RecordingSink>());
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kResourceExhausted);
  EXPECT_NE(refused.status().message().find("limit of 2 concurrent ingest streams"),
            std::string::npos);
  Send(a, IngestEnd{});
  ASSERT_TRUE(a.sink->Wait().ok());
  // Finished is enough: the place is free before the reaper has destroyed the session.
  Stream c = Open(manager, "a", 1);
  ASSERT_NE(c.session, nullptr);
  Send(b, IngestEnd{});
  Send(c, IngestEnd{});
  EXPECT_TRUE(b.sink->Wait().ok());
  EXPECT_TRUE(c.sink->Wait().ok());
  EXPECT_TRUE(WaitUntilNoneOwned(manager));
}

TEST_F(IngestManagerTest, MapLimitsAreValidated) {
  IngestOptions options;
  options.max_open_maps = 0;
  EXPECT_FALSE(options.Validate().ok());
  options.max_open_maps = 2;
  options.max_idle_maps = 3;
  EXPECT_FALSE(options.Validate().ok());
  options.max_idle_maps = 2;
  EXPECT_TRUE(options.Validate().ok());
}

TEST_F(IngestManagerTest, TheRevisitRulesTwoHalvesGoTogether) {
  IngestOptions options;
  EXPECT_TRUE(options.Validate().ok());  // both on by default
  options.keyframes.skip_mapped_views = false;
  const Status half = options.Validate();
  EXPECT_EQ(half.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(half.message().find("follow_revisits"), std::string::npos) << half.ToString();
  options.slam.follow_revisits = false;
  EXPECT_TRUE(options.Validate().ok());
  options.keyframes.skip_mapped_views = true;
  EXPECT_FALSE(options.Validate().ok());
}

}  // namespace
}  // namespace semmap
