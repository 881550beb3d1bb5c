// One pipeline stage: a thread, a bounded shutdown-aware input queue, a Flush barrier, errors
// recorded and surfaced, queue and latency metrics, and a synchronous mode for tests. Every
// per-map worker (the SLAM back end, the layer builder, the object mapper, and whatever comes
// next) is one of these, so none writes its own thread, queue, promise or error bookkeeping.
//
// A stage derives from PipelineStage<Event> and implements Handle; the optional hooks run on
// the stage's thread too:
//   OnStart  once, before the first event (restores read what they need here)
//   OnIdle   whenever the queue runs empty (deferred work); may ask to be called again at a
//            time even if no event arrives (a periodic persist)
//   OnFlush  at a Flush barrier, after every earlier event was handled (wait for writes)
//   OnStop   once, after the queue is shut down and drained
// Errors: a stage reports what fails with RecordError (logged, counted, kept); the next Flush
// returns the first one since the previous Flush, so nothing fails silently.
//
// Derived classes must call Stop() in their destructor (the thread calls their overrides).
#pragma once

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cstdint>
#include <future>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <variant>

#include "common/bounded_queue.h"
#include "common/latency_stats.h"
#include "common/logging.h"
#include "common/status.h"
#include "common/thread_annotations.h"
#include "common/thread_launcher.h"
#include "common/thread_priority.h"

namespace semmap {

struct StageMetrics {
  std::string name;
  size_t queue_depth = 0;
  size_t queue_capacity = 0;
  size_t queue_high_water = 0;
  uint64_t handled = 0;          // events handled
  uint64_t errors = 0;           // RecordError calls
  LatencySummary queue_wait_ms;  // from Submit to the start of Handle
  LatencySummary handle_ms;      // Handle itself
};

struct StageConfig {
  std::string name;            // in errors, logs and metrics ("slam back end")
  size_t queue_capacity = 64;  // events waiting for the thread; Submit blocks beyond
  // Synchronous: no thread; Submit handles the event on the caller's thread (then OnIdle),
  // Flush runs OnFlush there. For tests and tools that want determinism.
  bool synchronous = false;
  ThreadTier tier = ThreadTier::kBackground;  // its thread's scheduling tier (thread_priority.h)
  std::string thread_name = "semmap-stage";   // as `top -H` and perf show it (15 bytes kept)
  ThreadLauncher launch_thread;               // empty: LaunchThread (tests make it fail)
};

template <typename Event>
class PipelineStage {
 public:
  using Clock = std::chrono::steady_clock;

  explicit PipelineStage(StageConfig config)
      : config_(std::move(config)),
        queue_(config_.queue_capacity),
        queue_wait_ms_(config_.name + " queue wait"),
        handle_ms_(config_.name + " handle") {}
  virtual ~PipelineStage() {
    // The derived destructor stopped the stage; stopping here would call into a destroyed
    // derived object from the thread.
    assert(!thread_.joinable() && "derived stages call Stop() in their destructor");
  }
  PipelineStage(const PipelineStage&) = delete;
  PipelineStage& operator=(const PipelineStage&) = delete;

  // Starts the thread (OnStart runs there first), or in synchronous mode runs OnStart here.
  // RESOURCE_EXHAUSTED when no thread can be started; FAILED_PRECONDITION when called twice.
  Status Start() SEMMAP_EXCLUDES(lifecycle_mutex_, sync_mutex_) {
    MutexLock lock(lifecycle_mutex_);
    if (started_) return FailedPreconditionError(config_.name + " was started already");
    started_ = true;
    if (config_.synchronous) {
      MutexLock sync(sync_mutex_);
      OnStart();
      sync_running_ = !stopped_;
      return OkStatus();
    }
    const ThreadLauncher& launch = config_.launch_thread;
    StatusOr<std::thread> thread =
        launch ? launch([this] { Run(); }) : LaunchThread([this] { Run(); });
    if (!thread.ok()) {
      stopped_ = true;
      queue_.Shutdown();
      return thread.status().WithContext(config_.name);
    }
    thread_ = std::move(thread).value();
    return OkStatus();
  }

  // Hands `event` to the stage; blocks while the queue is full (backpressure).
  // UNAVAILABLE once the stage is stopped (or was never started).
  Status Submit(Event event) SEMMAP_EXCLUDES(lifecycle_mutex_, sync_mutex_) {
    if (config_.synchronous) {
      MutexLock sync(sync_mutex_);
      if (!sync_running_) return StoppedError();
      HandleTimed(event, Clock::now());
      OnIdle();
      return OkStatus();
    }
    if (!IsRunning() || !queue_.Push(Item{std::move(event), Clock::now()})) return StoppedError();
    return OkStatus();
  }

  // Like Submit but never blocks: RESOURCE_EXHAUSTED when the queue is full (`event` is left
  // untouched), UNAVAILABLE once stopped.
  Status TrySubmit(Event& event) SEMMAP_EXCLUDES(lifecycle_mutex_, sync_mutex_) {
    if (config_.synchronous) return Submit(std::move(event));
    if (!IsRunning()) return StoppedError();
    Item item{std::move(event), Clock::now()};
    if (!queue_.TryPush(item)) {
      event = std::move(std::get<Event>(item.payload));
      if (queue_.is_shutdown()) return StoppedError();
      return ResourceExhaustedError(config_.name + " queue is full (" +
                                    std::to_string(queue_.capacity()) + " events)");
    }
    return OkStatus();
  }

  // Waits until every event submitted before this call is handled and OnFlush returned;
  // returns the first error recorded since the last Flush, else OnFlush's status.
  // UNAVAILABLE once stopped.
  Status Flush() SEMMAP_EXCLUDES(lifecycle_mutex_, sync_mutex_) {
    if (config_.synchronous) {
      MutexLock sync(sync_mutex_);
      if (!sync_running_) return StoppedError();
      return FlushHere();
    }
    auto done = std::make_shared<std::promise<Status>>();
    std::future<Status> result = done->get_future();
    if (!IsRunning() || !queue_.Push(Item{Barrier{done}, Clock::now()})) return StoppedError();
    return result.get();
  }

  // Shuts the queue, lets the thread handle what is queued and run OnStop, joins it.
  // Idempotent; later Submit and Flush calls answer UNAVAILABLE.
  void Stop() SEMMAP_EXCLUDES(lifecycle_mutex_, sync_mutex_) {
    MutexLock lock(lifecycle_mutex_);
    if (stopped_) return;
    stopped_ = true;
    queue_.Shutdown();
    if (config_.synchronous) {
      MutexLock sync(sync_mutex_);
      if (sync_running_) {
        sync_running_ = false;
        OnStop();
      }
      return;
    }
    if (thread_.joinable()) thread_.join();
  }

  StageMetrics metrics() const SEMMAP_EXCLUDES(metrics_mutex_) {
    MutexLock lock(metrics_mutex_);
    StageMetrics m = metrics_;
    m.name = config_.name;
    m.queue_depth = queue_.size();
    m.queue_capacity = queue_.capacity();
    m.queue_high_water = queue_.high_water();
    m.queue_wait_ms = queue_wait_ms_.Summarize();
    m.handle_ms = handle_ms_.Summarize();
    return m;
  }
  const std::string& name() const { return config_.name; }

 protected:
  virtual void OnStart() {}
  virtual void Handle(Event& event) = 0;
  // Deferred work when the queue is empty. A time asks for another call then, even without
  // events (a past time: right away); nullopt waits for the next event.
  virtual std::optional<Clock::time_point> OnIdle() { return std::nullopt; }
  virtual Status OnFlush() { return OkStatus(); }
  virtual void OnStop() {}

  // Logged with the stage's name, counted, and returned by the next Flush (the first one).
  void RecordError(const Status& status) SEMMAP_EXCLUDES(metrics_mutex_) {
    if (status.ok()) return;
    LogError("{}: {}", config_.name, status.ToString());
    MutexLock lock(metrics_mutex_);
    ++metrics_.errors;
    if (first_error_.ok()) first_error_ = status;
  }

 private:
  struct Barrier {
    std::shared_ptr<std::promise<Status>> done;
  };
  struct Item {
    std::variant<Event, Barrier> payload;
    Clock::time_point submitted;
  };

  bool IsRunning() const SEMMAP_EXCLUDES(lifecycle_mutex_) {
    MutexLock lock(lifecycle_mutex_);
    return started_ && !stopped_;
  }
  Status StoppedError() const { return UnavailableError(config_.name + " stopped"); }

  void HandleTimed(Event& event, Clock::time_point submitted) SEMMAP_EXCLUDES(metrics_mutex_) {
    const Clock::time_point start = Clock::now();
    Handle(event);
    const Clock::time_point end = Clock::now();
    MutexLock lock(metrics_mutex_);
    ++metrics_.handled;
    queue_wait_ms_.Add(std::chrono::duration<double, std::milli>(start - submitted).count());
    handle_ms_.Add(std::chrono::duration<double, std::milli>(end - start).count());
  }

  Status FlushHere() SEMMAP_EXCLUDES(metrics_mutex_) {
    Status flushed = OnFlush();
    MutexLock lock(metrics_mutex_);
    Status first = std::move(first_error_);
    first_error_ = OkStatus();
    return first.ok() ? flushed : first;
  }

  void Run() {
    NameCurrentThread(config_.thread_name);
    RunCurrentThreadAs(config_.tier);
    OnStart();
    for (;;) {
      std::optional<Item> item = queue_.TryPop();
      if (!item) {
        const std::optional<Clock::time_point> wake = OnIdle();
        item = wake ? queue_.PopFor(std::max(Clock::duration::zero(), *wake - Clock::now()))
                    : queue_.Pop();
        if (!item) {
          if (queue_.is_shutdown() && queue_.size() == 0) break;
          continue;  // the wake-up time came: OnIdle again
        }
      }
      if (auto* barrier = std::get_if<Barrier>(&item->payload)) {
        barrier->done->set_value(FlushHere());
      } else {
        HandleTimed(std::get<Event>(item->payload), item->submitted);
      }
    }
    OnStop();
  }

  const StageConfig config_;
  BoundedQueue<Item> queue_;
  // Lock order: lifecycle_mutex_ before sync_mutex_; metrics_mutex_ is never held around
  // another lock.
  mutable Mutex lifecycle_mutex_;
  bool started_ SEMMAP_GUARDED_BY(lifecycle_mutex_) = false;
  bool stopped_ SEMMAP_GUARDED_BY(lifecycle_mutex_) = false;
  std::thread thread_ SEMMAP_GUARDED_BY(lifecycle_mutex_);
  // Synchronous mode: one caller in the hooks at a time; Submit and Flush take only this one.
  Mutex sync_mutex_;
  bool sync_running_ SEMMAP_GUARDED_BY(sync_mutex_) = false;  // after OnStart, before OnStop

  mutable Mutex metrics_mutex_;
  StageMetrics metrics_ SEMMAP_GUARDED_BY(metrics_mutex_);
  Status first_error_ SEMMAP_GUARDED_BY(metrics_mutex_);
  LatencyStats queue_wait_ms_ SEMMAP_GUARDED_BY(metrics_mutex_);
  LatencyStats handle_ms_ SEMMAP_GUARDED_BY(metrics_mutex_);
};

}  // namespace semmap
