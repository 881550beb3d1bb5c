// A bounded, shutdown-aware multi-producer/multi-consumer queue between pipeline stages.
// Producers either block (Push) or learn that the queue is full (TryPush) so the caller can
// apply backpressure upstream; nothing here grows without bound.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>

namespace semmap {

template <typename T>
class BoundedQueue {
 public:
  explicit BoundedQueue(size_t capacity) : capacity_(capacity == 0 ? 1 : capacity) {}
  BoundedQueue(const BoundedQueue&) = delete;
  BoundedQueue& operator=(const BoundedQueue&) = delete;

  // Blocks while full. Returns false (and drops nothing) once the queue is shut down.
  bool Push(T item) {
    std::unique_lock lock(mutex_);
    not_full_.wait(lock, [&] { return shutdown_ || items_.size() < capacity_; });
    if (shutdown_) return false;
    items_.push_back(std::move(item));
    not_empty_.notify_one();
    return true;
  }

  // Never blocks: false when full or shut down, and `item` is left untouched.
  bool TryPush(T& item) {
    std::lock_guard lock(mutex_);
    if (shutdown_ || items_.size() >= capacity_) return false;
    items_.push_back(std::move(item));
    not_empty_.notify_one();
    return true;
  }

  // Blocks until an item arrives; after shutdown it still drains what was queued, then
  // returns nullopt.
  std::optional<T> Pop() {
    std::unique_lock lock(mutex_);
    not_empty_.wait(lock, [&] { return shutdown_ || !items_.empty(); });
    return PopLocked();
  }

  // Like Pop but gives up after `timeout` (returns nullopt).
  template <typename Rep, typename Period>
  std::optional<T> PopFor(std::chrono::duration<Rep, Period> timeout) {
    std::unique_lock lock(mutex_);
    not_empty_.wait_for(lock, timeout, [&] { return shutdown_ || !items_.empty(); });
    return PopLocked();
  }

  std::optional<T> TryPop() {
    std::lock_guard lock(mutex_);
    return PopLocked();
  }

  // Wakes every waiter; later pushes fail, pops drain the remaining items.
  void Shutdown() {
    std::lock_guard lock(mutex_);
    shutdown_ = true;
    not_empty_.notify_all();
    not_full_.notify_all();
  }

  size_t size() const {
    std::lock_guard lock(mutex_);
    return items_.size();
  }
  size_t capacity() const { return capacity_; }
  bool is_shutdown() const {
    std::lock_guard lock(mutex_);
    return shutdown_;
  }

 private:
  std::optional<T> PopLocked() {
    if (items_.empty()) return std::nullopt;
    T item = std::move(items_.front());
    items_.pop_front();
    not_full_.notify_one();
    return item;
  }

  const size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable not_empty_;
  std::condition_variable not_full_;
  std::deque<T> items_;
  bool shutdown_ = false;
};

}  // namespace semmap
