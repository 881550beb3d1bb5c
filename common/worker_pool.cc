#include "common/worker_pool.h"

#include "common/thread_launcher.h"
#include "common/thread_priority.h"

namespace semmap {

Status WorkerPoolOptions::Validate() const {
  if (threads == 0 || threads > 256) {
    return InvalidArgumentError("worker threads must be 1..256, got " + std::to_string(threads));
  }
  if (queue_capacity == 0 || queue_capacity > 100000) {
    return InvalidArgumentError("worker queue capacity must be 1..100000, got " +
                                std::to_string(queue_capacity));
  }
  if (thread_name.empty() || thread_name.size() > 15) {
    return InvalidArgumentError("worker thread name must be 1..15 characters");
  }
  return OkStatus();
}

StatusOr<std::unique_ptr<WorkerPool>> WorkerPool::Start(const WorkerPoolOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  std::unique_ptr<WorkerPool> pool(new WorkerPool(options));
  for (size_t i = 0; i < options.threads; ++i) {
    StatusOr<std::thread> thread = LaunchThread([p = pool.get()] { p->Run(); });
    if (!thread.ok()) return thread.status();  // ~WorkerPool stops those already started
    pool->threads_.push_back(std::move(thread).value());
  }
  return pool;
}

WorkerPool::~WorkerPool() { Stop(); }

Status WorkerPool::Submit(std::function<void()> work) {
  if (!queue_.TryPush(work)) {
    if (queue_.is_shutdown()) return UnavailableError("the server is shutting down");
    return ResourceExhaustedError("the server's call queue is full (" +
                                  std::to_string(options_.queue_capacity) +
                                  " calls waiting for a worker); retry later");
  }
  return OkStatus();
}

void WorkerPool::Stop() {
  queue_.Shutdown();
  for (std::thread& thread : threads_) {
    if (thread.joinable()) thread.join();
  }
}

void WorkerPool::Run() {
  NameCurrentThread(options_.thread_name);
  while (std::optional<std::function<void()>> work = queue_.Pop()) {
    running_.fetch_add(1);
    (*work)();
    running_.fetch_sub(1);
  }
}

}  // namespace semmap
