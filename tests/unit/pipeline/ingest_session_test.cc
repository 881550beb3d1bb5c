// IngestSession against a real StorageWriter on a temporary SQLite database, with a recording
// sink: ordering rules, acks, durability and the final status.
#include "core/pipeline/ingest_session.h"

#include <gtest/gtest.h>

#include <condition_variable>
#include <future>

#include "storage/sqlite/sqlite_map_store.h"
#include "tests/testing/synthetic_frames.h"
#include "tests/testing/temp_dir.h"
#include "tests/unit/pipeline/recording_sink.h"

namespace semmap {
namespace {

using testing::RecordingSink;

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
    frame.stamp_ns = static_cast<int64_t>(seq % 1'000'000) * 1000;  // any seq, even 2^63
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

  std::unique_ptr<IngestSession> StartSession(IngestOptions options = {}) {
    StatusOr<std::unique_ptr<IngestSession>> session =
        IngestSession::Start(sink_, writer_.get(), std::move(options));
    EXPECT_TRUE(session.ok()) << session.status().ToString();
    return session.ok() ? std::move(session).value() : nullptr;
  }

  SessionInfo StoredSession(const std::string& name) {
    SessionInfo info;
    Status read = writer_->RunSync([&](MapStore& store) -> Status {
      SEMMAP_ASSIGN_OR_RETURN(info, store.GetSession("m", name));
      return OkStatus();
    });
    EXPECT_TRUE(read.ok()) << read.ToString();
    return info;
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
  std::unique_ptr<IngestSession> session = StartSession();
  std::vector<IngestMessage> messages;
  messages.emplace_back(Start("a"));
  for (int i = 0; i < 10; ++i) messages.emplace_back(Frame(i, 0.06 * i));
  messages.emplace_back(IngestEnd{});
  Feed(*session, std::move(messages));
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
  const SessionInfo stored = StoredSession("a");
  EXPECT_EQ(stored.end_reason, SessionEndReason::kCompleted);
  EXPECT_EQ(stored.end_message, "");
}

TEST_F(IngestSessionTest, FrameBeforeStartFails) {
  std::unique_ptr<IngestSession> session = StartSession();
  Feed(*session, {Frame(0, 0)});
  EXPECT_EQ(sink_->Wait().code(), StatusCode::kInvalidArgument);
}

TEST_F(IngestSessionTest, ErrorKeepsEarlierFrames) {
  std::unique_ptr<IngestSession> session = StartSession();
  Feed(*session, {Start("b"), Frame(0, 0), Frame(1, 0), Frame(1, 0)});
  const Status status = sink_->Wait();
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("frames up to seq 1 are stored"), std::string::npos)
      << status.message();
  const SessionInfo stored = StoredSession("b");
  EXPECT_EQ(stored.end_reason, SessionEndReason::kError);
  EXPECT_NE(stored.end_message.find("INVALID_ARGUMENT: frame seq 1 is not greater"),
            std::string::npos)
      << stored.end_message;
}

// Stored seqs are int64: a larger one is refused before it is acknowledged.
TEST_F(IngestSessionTest, SeqAbove2To63IsRefusedBeforeItsAck) {
  std::unique_ptr<IngestSession> session = StartSession();
  Feed(*session, {Start("seq"), Frame(0, 0), Frame(uint64_t{1} << 63, 0.2)});
  const Status status = sink_->Wait();
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("above the largest allowed seq, 2^63 - 1"), std::string::npos)
      << status.message();
  EXPECT_EQ(sink_->acks.size(), 1u);
  EXPECT_EQ(sink_->final_summary.durable_seq, 0u);
}

TEST_F(IngestSessionTest, IdleStreamEndsWithDeadlineExceededKeepingItsFrames) {
  IngestOptions options;
  options.idle_timeout_s = 0.3;
  std::unique_ptr<IngestSession> session = StartSession(options);
  Feed(*session, {Start("idle"), Frame(0, 0), Frame(1, 0.2)});
  const Status status = sink_->Wait();  // nothing more is sent
  EXPECT_EQ(status.code(), StatusCode::kDeadlineExceeded);
  EXPECT_NE(status.message().find("no message from the client for 0.3 s"), std::string::npos)
      << status.message();
  EXPECT_NE(status.message().find("frames up to seq 1 are stored"), std::string::npos);
  EXPECT_EQ(sink_->acks.size(), 2u);
  const SessionInfo stored = StoredSession("idle");
  EXPECT_EQ(stored.end_reason, SessionEndReason::kIdleTimeout);
  EXPECT_EQ(stored.frame_count, 2);
  IngestMessage late = Frame(2, 0.4);
  EXPECT_FALSE(session->TryEnqueue(late));  // the stream is over
}

// Either of the two threads failing to start is RESOURCE_EXHAUSTED, never std::terminate.
TEST_F(IngestSessionTest, ThreadStartFailureIsResourceExhausted) {
  for (int fail_at : {1, 2}) {
    auto calls = std::make_shared<int>(0);
    IngestOptions options;
    options.launch_thread = [calls, fail_at](std::function<void()> body) -> StatusOr<std::thread> {
      if (++*calls == fail_at) return ResourceExhaustedError("no threads left (test)");
      return LaunchThread(std::move(body));
    };
    StatusOr<std::unique_ptr<IngestSession>> session =
        IngestSession::Start(sink_, writer_.get(), options);
    ASSERT_FALSE(session.ok()) << fail_at;
    EXPECT_EQ(session.status().code(), StatusCode::kResourceExhausted);
    EXPECT_NE(session.status().message().find("no threads left"), std::string::npos);
    EXPECT_FALSE(sink_->final_status.has_value());  // it never started, so never reports
  }
}

TEST_F(IngestSessionTest, CancelStoresQueuedFramesAndReportsCancelled) {
  std::unique_ptr<IngestSession> session = StartSession();
  Feed(*session, {Start("c"), Frame(0, 0), Frame(1, 0.2)});
  session->Cancel();
  EXPECT_EQ(sink_->Wait().code(), StatusCode::kCancelled);
  EXPECT_EQ(sink_->final_summary.frames, 2u);
  EXPECT_EQ(StoredSession("c").end_reason, SessionEndReason::kCancelled);
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
  std::unique_ptr<IngestSession> session = StartSession(options);
  IngestMessage start = Start("d");
  ASSERT_TRUE(session->TryEnqueue(start));
  int accepted = 0;
  for (int i = 0; i < 10; ++i) {
    IngestMessage frame = Frame(i, 0);
    if (session->TryEnqueue(frame)) ++accepted;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  // The input queue, the decoded frames waiting for the blocked worker and the one the decoder
  // holds: nothing beyond that.
  EXPECT_LE(accepted,
            static_cast<int>(options.queue_capacity + IngestSession::kStagedCapacity + 1));
  release.set_value();
  holder.join();
  session->Stop();
  EXPECT_EQ(sink_->Wait().code(), StatusCode::kUnavailable);
  EXPECT_EQ(StoredSession("d").end_reason, SessionEndReason::kServerStopped);
}

}  // namespace
}  // namespace semmap
