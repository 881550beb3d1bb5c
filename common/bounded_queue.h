// A bounded, shutdown-aware multi-producer/multi-consumer queue between pipeline stages.
// Producers either block (Push) or learn that the queue is full (TryPush) so the caller can
// apply backpressure upstream; nothing here grows without bound.
#pragma once

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <optional>

#include "common/thread_annotations.h"

namespace semmap {

template <typename T>
class BoundedQueue {
 public:
  explicit BoundedQueue(size_t capacity) : capacity_(capacity == 0 ? 1 : capacity) {}
  BoundedQueue(const BoundedQueue&) = delete;
  BoundedQueue& operator=(const BoundedQueue&) = delete;

  // Blocks while full. Returns false (and drops nothing) once the queue is shut down.
  bool Push(T item) SEMMAP_EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    while (!shutdown_ && items_.size() >= capacity_) not_full_.wait(lock);
    if (shutdown_) return false;
    items_.push_back(std::move(item));
    high_water_ = std::max(high_water_, items_.size());
    not_empty_.notify_one();
    return true;
  }

  // Never blocks: false when full or shut down, and `item` is left untouched.
  bool TryPush(T& item) SEMMAP_EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    if (shutdown_ || items_.size() >= capacity_) return false;
    items_.push_back(std::move(item));
    high_water_ = std::max(high_water_, items_.size());
    not_empty_.notify_one();
    return true;
  }

  // Blocks until an item arrives; after shutdown it still drains what was queued, then
  // returns nullopt.
  std::optional<T> Pop() SEMMAP_EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    while (!shutdown_ && items_.empty()) not_empty_.wait(lock);
    return PopLocked();
  }

  // Like Pop but gives up after `timeout` (returns nullopt).
  template <typename Rep, typename Period>
  std::optional<T> PopFor(std::chrono::duration<Rep, Period> timeout) SEMMAP_EXCLUDES(mutex_) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    MutexLock lock(mutex_);
    while (!shutdown_ && items_.empty()) {
      if (not_empty_.wait_until(lock, deadline) == std::cv_status::timeout) break;
    }
    return PopLocked();
  }

  std::optional<T> TryPop() SEMMAP_EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    return PopLocked();
  }

  // Wakes every waiter; later pushes fail, pops drain the remaining items.
  void Shutdown() SEMMAP_EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    shutdown_ = true;
    not_empty_.notify_all();
    not_full_.notify_all();
  }

  // The most items it held at once (right after a push).
  size_t high_water() const SEMMAP_EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    return high_water_;
  }
  size_t size() const SEMMAP_EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    return items_.size();
  }
  size_t capacity() const { return capacity_; }
  bool is_shutdown() const SEMMAP_EXCLUDES(mutex_) {
    MutexLock lock(mutex_);
    return shutdown_;
  }

 private:
  std::optional<T> PopLocked() SEMMAP_REQUIRES(mutex_) {
    if (items_.empty()) return std::nullopt;
    T item = std::move(items_.front());
    items_.pop_front();
    not_full_.notify_one();
    return item;
  }

  const size_t capacity_;
  mutable Mutex mutex_;
  std::condition_variable_any not_empty_;  // waits on a MutexLock of mutex_
  std::condition_variable_any not_full_;
  std::deque<T> items_ SEMMAP_GUARDED_BY(mutex_);
  size_t high_water_ SEMMAP_GUARDED_BY(mutex_) = 0;
  bool shutdown_ SEMMAP_GUARDED_BY(mutex_) = false;
};

}  // namespace semmap
