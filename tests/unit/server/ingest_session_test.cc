// IngestSession against a real StorageWriter on a temporary SQLite database, with a recording
// sink: ordering rules, acks, durability and the final status.
#include "server/ingest/ingest_session.h"

#include <gtest/gtest.h>

#include <condition_variable>
#include <future>

#include "storage/sqlite/sqlite_map_store.h"
#include "tests/testing/synthetic_frames.h"
#include "tests/testing/temp_dir.h"

namespace semmap {
namespace {

class RecordingSink final : public IngestSink {
 public:
  void OnStarted(const SessionInfo& s) override {
    std::lock_guard lock(mutex_);
    started = s;
  }
  void OnAck(const FrameAckInfo& a) override {
    std::lock_guard lock(mutex_);
    acks.push_back(a);
  }
  void OnProgress(const IngestProgressInfo&) override {}
  void OnQueueRoom() override {}
  void OnFinished(const Status& s, const IngestSummaryInfo& summary) override {
    std::lock_guard lock(mutex_);
    final_status = s;
    final_summary = summary;
    done.notify_all();
  }
  Status Wait() {
    std::unique_lock lock(mutex_);
    done.wait(lock, [&] { return final_status.has_value(); });
    return *final_status;
  }

  std::mutex mutex_;
  std::condition_variable done;
  std::optional<SessionInfo> started;
  std::vector<FrameAckInfo> acks;
  std::optional<Status> final_status;
  IngestSummaryInfo final_summary;
};

class IngestSessionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto store = SqliteMapStore::Open(dir_.File("db.sqlite"), SqliteOptions{});
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    auto writer = StorageWriter::Start(std::move(store).value(), StorageWriter::Options{});
    ASSERT_TRUE(writer.ok());
    writer_ = std::move(writer).value();
    sink_ = std::make_shared<RecordingSink>();
  }

  IngestStartRequest Start(const std::string& session) {
    IngestStartRequest start;
    start.map = "m";
    start.session = session;
    start.mode = SessionMode::kKnownPoses;
    start.camera = testing::TestCamera(64, 48);
    return start;
  }

  IngestFrame Frame(uint64_t seq, double x) {
    IngestFrame frame;
    frame.seq = seq;
    frame.stamp_ns = static_cast<int64_t>(seq) * 1000;
    ImageMessage colour;
    colour.kind = ImageMessage::Kind::kCompressed;
    colour.encoding = "png";
    colour.data = testing::EncodePng(testing::TexturedImage(64, 48, 3));
    frame.colour = colour;
    PoseTq pose;
    pose.t.x() = x;
    frame.pose_prior = pose;
    return frame;
  }

  // Pushes all messages, waiting for room when the queue is full.
  void Feed(IngestSession& session, std::vector<IngestMessage> messages) {
    for (auto& m : messages) {
      while (!session.TryEnqueue(m)) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }

  testing::TempDir dir_;
  std::unique_ptr<StorageWriter> writer_;
  std::shared_ptr<RecordingSink> sink_;
};

TEST_F(IngestSessionTest, StoresFramesAndReportsDurableSeq) {
  IngestSession session(sink_, writer_.get(), IngestOptions{});
  std::vector<IngestMessage> messages;
  messages.push_back(Start("a"));
  for (int i = 0; i < 10; ++i) messages.push_back(Frame(i, 0.06 * i));
  messages.push_back(IngestEnd{});
  Feed(session, std::move(messages));
  ASSERT_TRUE(sink_->Wait().ok()) << sink_->final_status->ToString();
  ASSERT_TRUE(sink_->started.has_value());
  EXPECT_EQ(sink_->started->name, "a");
  ASSERT_EQ(sink_->acks.size(), 10u);
  // 6 cm steps with a 10 cm threshold: keyframes at 0, 2, 4, 6, 8.
  int keyframes = 0;
  for (const auto& a : sink_->acks) keyframes += a.is_keyframe;
  EXPECT_EQ(keyframes, 5);
  EXPECT_EQ(sink_->final_summary.frames, 10u);
  EXPECT_EQ(sink_->final_summary.durable_seq, 9u);
}

TEST_F(IngestSessionTest, FrameBeforeStartFails) {
  IngestSession session(sink_, writer_.get(), IngestOptions{});
  Feed(session, {Frame(0, 0)});
  EXPECT_EQ(sink_->Wait().code(), StatusCode::kInvalidArgument);
}

TEST_F(IngestSessionTest, ErrorKeepsEarlierFrames) {
  IngestSession session(sink_, writer_.get(), IngestOptions{});
  Feed(session, {Start("b"), Frame(0, 0), Frame(1, 0), Frame(1, 0)});
  const Status status = sink_->Wait();
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("frames up to seq 1 are stored"), std::string::npos)
      << status.message();
}

TEST_F(IngestSessionTest, CancelStoresQueuedFramesAndReportsCancelled) {
  IngestSession session(sink_, writer_.get(), IngestOptions{});
  Feed(session, {Start("c"), Frame(0, 0), Frame(1, 0.2)});
  session.Cancel();
  EXPECT_EQ(sink_->Wait().code(), StatusCode::kCancelled);
  EXPECT_EQ(sink_->final_summary.frames, 2u);
}

TEST_F(IngestSessionTest, QueueIsBounded) {
  IngestOptions options;
  options.queue_capacity = 2;
  // Stall the writer so the worker blocks on its first frame and the queue fills up.
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::promise<void> holding;
  std::thread holder([&] {
    Status s = writer_->RunSync([&](MapStore&) {
      holding.set_value();
      released.wait();
      return OkStatus();
    });
    (void)s;
  });
  holding.get_future().wait();
  IngestSession session(sink_, writer_.get(), options);
  IngestMessage start = Start("d");
  ASSERT_TRUE(session.TryEnqueue(start));
  int accepted = 0;
  for (int i = 0; i < 10; ++i) {
    IngestMessage frame = Frame(i, 0);
    if (session.TryEnqueue(frame)) ++accepted;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  // The input queue, the decoded frames waiting for the blocked worker and the one the decoder
  // holds: nothing beyond that.
  EXPECT_LE(accepted,
            static_cast<int>(options.queue_capacity + IngestSession::kStagedCapacity + 1));
  release.set_value();
  holder.join();
  session.Stop();
  EXPECT_EQ(sink_->Wait().code(), StatusCode::kUnavailable);
}

}  // namespace
}  // namespace semmap
