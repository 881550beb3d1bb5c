// A fixed set of threads running submitted work from a bounded queue. The gRPC edge runs
// queries, exports and object registrations here instead of on gRPC's callback threads, so a
// slow call occupies a worker, not the threads every other call needs. A full queue is refused
// at once (RESOURCE_EXHAUSTED), never waited on: the caller is a gRPC callback.
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "common/bounded_queue.h"
#include "common/status.h"

namespace semmap {

struct WorkerPoolOptions {
  size_t threads = 4;
  size_t queue_capacity = 64;          // work waiting for a thread
  std::string thread_name = "worker";  // shown by top -H / gdb (15 characters at most)

  Status Validate() const;
};

class WorkerPool {
 public:
  // Starts the threads; INVALID_ARGUMENT for bad options, RESOURCE_EXHAUSTED when a thread
  // cannot be started.
  static StatusOr<std::unique_ptr<WorkerPool>> Start(const WorkerPoolOptions& options);
  ~WorkerPool();  // Stop()
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  // Queues `work` for the next free thread. RESOURCE_EXHAUSTED when queue_capacity items are
  // already waiting, UNAVAILABLE after Stop(); `work` is not run then.
  Status Submit(std::function<void()> work);

  // Takes no more work, runs what is queued, joins the threads. Idempotent.
  void Stop();

  size_t running() const { return running_.load(); }  // work items being run right now
  size_t queued() const { return queue_.size(); }
  size_t threads() const { return threads_.size(); }

 private:
  explicit WorkerPool(const WorkerPoolOptions& options)
      : options_(options), queue_(options.queue_capacity) {}
  void Run();

  const WorkerPoolOptions options_;
  BoundedQueue<std::function<void()>> queue_;
  std::atomic<size_t> running_{0};
  std::vector<std::thread> threads_;  // set in Start, joined in Stop (one caller)
};

}  // namespace semmap
