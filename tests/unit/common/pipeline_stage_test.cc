#include "common/pipeline_stage.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace semmap {
namespace {

using namespace std::chrono_literals;

// Records what it handles; can be held inside Handle until released, and fails events < 0.
class RecordingStage final : public PipelineStage<int> {
 public:
  explicit RecordingStage(StageConfig config) : PipelineStage(std::move(config)) {}
  ~RecordingStage() override { Stop(); }

  void Hold() {
    std::lock_guard lock(mutex_);
    held_ = true;
  }
  void Release() {
    {
      std::lock_guard lock(mutex_);
      held_ = false;
    }
    changed_.notify_all();
  }
  // Waits until Handle is blocked in a hold (the thread has taken an event out of the queue).
  bool WaitUntilInside() {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, 5s, [&] { return inside_; });
  }
  std::vector<int> handled() const {
    std::lock_guard lock(mutex_);
    return handled_;
  }
  int idles() const { return idles_.load(); }
  int flushes() const { return flushes_.load(); }
  bool started_hook() const { return started_hook_.load(); }
  bool stopped_hook() const { return stopped_hook_.load(); }
  std::thread::id handler_thread() const {
    std::lock_guard lock(mutex_);
    return handler_thread_;
  }
  void WakeIdleAfter(std::chrono::milliseconds delay) { idle_wake_ = delay; }
  void FailNextFlush(Status status) {
    std::lock_guard lock(mutex_);
    flush_status_ = std::move(status);
  }

 protected:
  void OnStart() override { started_hook_ = true; }
  void Handle(int& event) override {
    std::unique_lock lock(mutex_);
    handler_thread_ = std::this_thread::get_id();
    inside_ = true;
    changed_.notify_all();
    changed_.wait(lock, [&] { return !held_; });
    inside_ = false;
    handled_.push_back(event);
    if (event < 0) {
      lock.unlock();
      RecordError(InvalidArgumentError("event " + std::to_string(event)));
    }
  }
  std::optional<Clock::time_point> OnIdle() override {
    ++idles_;
    if (idle_wake_.count() == 0) return std::nullopt;
    return Clock::now() + idle_wake_;
  }
  Status OnFlush() override {
    ++flushes_;
    std::lock_guard lock(mutex_);
    Status s = std::move(flush_status_);
    flush_status_ = OkStatus();
    return s;
  }
  void OnStop() override { stopped_hook_ = true; }

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool held_ = false;
  bool inside_ = false;
  std::vector<int> handled_;
  std::thread::id handler_thread_;
  Status flush_status_;
  std::atomic<int> idles_{0};
  std::atomic<int> flushes_{0};
  std::atomic<bool> started_hook_{false};
  std::atomic<bool> stopped_hook_{false};
  std::chrono::milliseconds idle_wake_{0};
};

StageConfig Config(size_t capacity, bool synchronous = false) {
  StageConfig c;
  c.name = "test stage";
  c.queue_capacity = capacity;
  c.synchronous = synchronous;
  return c;
}

TEST(PipelineStageTest, FlushWaitsForEveryEarlierEventOnTheStageThread) {
  RecordingStage stage(Config(4));
  ASSERT_TRUE(stage.Start().ok());
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(stage.Submit(i).ok());
  ASSERT_TRUE(stage.Flush().ok());
  std::vector<int> expected(20);
  for (int i = 0; i < 20; ++i) expected[i] = i;
  EXPECT_EQ(stage.handled(), expected);  // all of them, in order
  EXPECT_EQ(stage.flushes(), 1);
  EXPECT_TRUE(stage.started_hook());
  EXPECT_NE(stage.handler_thread(), std::this_thread::get_id());
  const StageMetrics m = stage.metrics();
  EXPECT_EQ(m.name, "test stage");
  EXPECT_EQ(m.handled, 20u);
  EXPECT_EQ(m.queue_capacity, 4u);
  EXPECT_LE(m.queue_high_water, 4u);
  EXPECT_GE(m.queue_high_water, 1u);
  EXPECT_EQ(m.handle_ms.count, 20u);
  EXPECT_EQ(m.queue_wait_ms.count, 20u);
  EXPECT_EQ(m.errors, 0u);
}

TEST(PipelineStageTest, ErrorsAreSurfacedByTheNextFlushOnlyAndCounted) {
  RecordingStage stage(Config(8));
  ASSERT_TRUE(stage.Start().ok());
  ASSERT_TRUE(stage.Submit(1).ok());
  ASSERT_TRUE(stage.Submit(-2).ok());
  ASSERT_TRUE(stage.Submit(-3).ok());
  const Status first = stage.Flush();
  EXPECT_EQ(first.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(first.message().find("event -2"), std::string::npos) << first.ToString();
  EXPECT_TRUE(stage.Flush().ok());  // reported once
  EXPECT_EQ(stage.metrics().errors, 2u);
  // OnFlush's own status comes back when nothing was recorded.
  stage.FailNextFlush(DataLossError("writes failed"));
  EXPECT_EQ(stage.Flush().code(), StatusCode::kDataLoss);
  EXPECT_TRUE(stage.Flush().ok());
}

TEST(PipelineStageTest, StopWhileFullUnblocksProducersAndDrainsWhatWasQueued) {
  RecordingStage stage(Config(2));
  ASSERT_TRUE(stage.Start().ok());
  stage.Hold();
  ASSERT_TRUE(stage.Submit(0).ok());
  ASSERT_TRUE(stage.WaitUntilInside());  // 0 is being handled; the queue is empty
  ASSERT_TRUE(stage.Submit(1).ok());
  ASSERT_TRUE(stage.Submit(2).ok());  // full now
  int refused = 3;
  EXPECT_EQ(stage.TrySubmit(refused).code(), StatusCode::kResourceExhausted);
  EXPECT_EQ(refused, 3);  // left untouched
  Status blocked_submit;
  std::thread producer([&] { blocked_submit = stage.Submit(4); });  // blocks: full
  std::this_thread::sleep_for(50ms);
  std::thread stopper([&] { stage.Stop(); });
  std::this_thread::sleep_for(50ms);
  stage.Release();
  producer.join();
  stopper.join();
  EXPECT_EQ(blocked_submit.code(), StatusCode::kUnavailable);
  EXPECT_EQ(stage.handled(), (std::vector<int>{0, 1, 2}));  // queued events were not dropped
  EXPECT_TRUE(stage.stopped_hook());
  EXPECT_EQ(stage.Submit(5).code(), StatusCode::kUnavailable);
  EXPECT_EQ(stage.TrySubmit(refused).code(), StatusCode::kUnavailable);
  EXPECT_EQ(stage.Flush().code(), StatusCode::kUnavailable);
  stage.Stop();  // idempotent
}

TEST(PipelineStageTest, AFlushWaitingBehindAStopStillGetsAnAnswer) {
  RecordingStage stage(Config(4));
  ASSERT_TRUE(stage.Start().ok());
  stage.Hold();
  ASSERT_TRUE(stage.Submit(0).ok());
  ASSERT_TRUE(stage.WaitUntilInside());
  Status flushed = InternalError("not answered");
  std::thread flusher([&] { flushed = stage.Flush(); });
  std::this_thread::sleep_for(50ms);
  std::thread stopper([&] { stage.Stop(); });
  std::this_thread::sleep_for(20ms);
  stage.Release();
  flusher.join();
  stopper.join();
  // Queued before the stop: handled like any event, so the flush completes.
  EXPECT_TRUE(flushed.ok()) << flushed.ToString();
}

TEST(PipelineStageTest, IdleHookRunsWhenTheQueueEmptiesAndAtTheTimeItAsks) {
  RecordingStage stage(Config(4));
  stage.WakeIdleAfter(10ms);
  ASSERT_TRUE(stage.Start().ok());
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (stage.idles() < 5 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(5ms);
  }
  EXPECT_GE(stage.idles(), 5);  // woken without events
}

TEST(PipelineStageTest, SynchronousModeHandlesOnTheCallersThread) {
  RecordingStage stage(Config(1, /*synchronous=*/true));
  EXPECT_EQ(stage.Submit(1).code(), StatusCode::kUnavailable);  // not started
  ASSERT_TRUE(stage.Start().ok());
  EXPECT_TRUE(stage.started_hook());
  ASSERT_TRUE(stage.Submit(1).ok());
  ASSERT_TRUE(stage.Submit(-2).ok());
  EXPECT_EQ(stage.handled(), (std::vector<int>{1, -2}));  // before Submit returned
  EXPECT_EQ(stage.handler_thread(), std::this_thread::get_id());
  EXPECT_EQ(stage.idles(), 2);
  EXPECT_EQ(stage.Flush().code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(stage.Flush().ok());
  stage.Stop();
  EXPECT_TRUE(stage.stopped_hook());
  EXPECT_EQ(stage.Submit(3).code(), StatusCode::kUnavailable);
}

TEST(PipelineStageTest, AThreadThatCannotStartIsResourceExhaustedAndNothingRuns) {
  StageConfig config = Config(4);
  config.launch_thread = [](const std::function<void()>&) -> StatusOr<std::thread> {
    return ResourceExhaustedError("no threads left");
  };
  RecordingStage stage(config);
  const Status started = stage.Start();
  EXPECT_EQ(started.code(), StatusCode::kResourceExhausted);
  EXPECT_NE(started.message().find("test stage"), std::string::npos) << started.ToString();
  EXPECT_EQ(stage.Submit(1).code(), StatusCode::kUnavailable);
  EXPECT_EQ(stage.Flush().code(), StatusCode::kUnavailable);
  EXPECT_FALSE(stage.started_hook());
  EXPECT_EQ(stage.Start().code(), StatusCode::kFailedPrecondition);
}

TEST(PipelineStageTest, ManyProducersAndFlushersAtOnce) {
  RecordingStage stage(Config(3));
  ASSERT_TRUE(stage.Start().ok());
  std::vector<std::thread> producers;
  producers.reserve(4);
  for (int p = 0; p < 4; ++p) {
    producers.emplace_back([&, p] {
      for (int i = 0; i < 50; ++i) {
        EXPECT_TRUE(stage.Submit(p * 1000 + i).ok());
        if (i % 10 == 0) {
          EXPECT_TRUE(stage.Flush().ok());
        }
      }
    });
  }
  for (std::thread& t : producers) t.join();
  ASSERT_TRUE(stage.Flush().ok());
  EXPECT_EQ(stage.handled().size(), 200u);
  EXPECT_EQ(stage.metrics().handled, 200u);
}

}  // namespace
}  // namespace semmap
