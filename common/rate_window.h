// "At most N events in any window of W seconds": the limit on object registrations per
// minute (each runs feature extraction over several photos). Thread-safe.
#pragma once

#include <chrono>
#include <cstddef>
#include <deque>

#include "common/thread_annotations.h"

namespace semmap {

class RateWindow {
 public:
  using Clock = std::chrono::steady_clock;

  // `max_events` 0: no limit.
  RateWindow(size_t max_events, Clock::duration window)
      : max_events_(max_events), window_(window) {}

  // Records an event at `now` and returns true, or returns false (recording nothing) when
  // max_events already happened in the window ending at `now`.
  bool TryAcquire(Clock::time_point now = Clock::now()) SEMMAP_EXCLUDES(mutex_) {
    if (max_events_ == 0) return true;
    MutexLock lock(mutex_);
    while (!events_.empty() && now - events_.front() >= window_) events_.pop_front();
    if (events_.size() >= max_events_) return false;
    events_.push_back(now);
    return true;
  }

  size_t max_events() const { return max_events_; }

 private:
  const size_t max_events_;
  const Clock::duration window_;
  Mutex mutex_;
  std::deque<Clock::time_point> events_ SEMMAP_GUARDED_BY(mutex_);
};

}  // namespace semmap
