// The single storage writer thread (DESIGN: one writer for SQLite). Pipelines hand it batches
// through a bounded queue (Submit blocks when full: backpressure); it commits what has queued up
// in one transaction and reports each batch's outcome through its callback.
#pragma once

#include <cstddef>
#include <functional>
#include <future>
#include <memory>
#include <thread>
#include <variant>
#include <vector>

#include "common/bounded_queue.h"
#include "common/status.h"
#include "common/thread_annotations.h"
#include "storage/map_store.h"

namespace semmap {

class StorageWriter {
 public:
  struct Options {
    size_t queue_capacity = 64;    // batches and sync calls waiting for the thread
    size_t max_batch_items = 256;  // most batches merged into one transaction
    Status Validate() const;
  };
  // Runs on the writer thread; must not call Submit, RunSync or Stop (they refuse).
  using Done = std::function<void(const Status&, const WriteResult&)>;

  // Takes ownership of the store it writes through (its own connection).
  static StatusOr<std::unique_ptr<StorageWriter>> Start(std::unique_ptr<MapStore> store,
                                                        Options options);
  ~StorageWriter();  // calls Stop()
  StorageWriter(const StorageWriter&) = delete;
  StorageWriter& operator=(const StorageWriter&) = delete;

  // Blocks while the queue is full. `done` runs on the writer thread once the transaction
  // holding this batch committed (OK, result has this batch's keyframe ids in order) or failed.
  // After Stop(): returns UNAVAILABLE and never calls done.
  Status Submit(WriteBatch batch, Done done);
  // Runs fn on the writer thread, after everything submitted before, and returns its status.
  // Blocks the caller.
  Status RunSync(std::function<Status(MapStore&)> fn);
  // Drains and commits everything queued, checkpoints the WAL and joins the thread.
  // Idempotent; returns the first error among the writes drained after Stop began and the
  // checkpoint (earlier write errors went to their callbacks).
  Status Stop() SEMMAP_EXCLUDES(stop_mutex_);

  // Batches and sync calls waiting for the thread (for progress reports and tests).
  size_t queue_depth() const { return queue_.size(); }

 private:
  struct PendingWrite {
    WriteBatch batch;
    Done done;
  };
  struct SyncCall {
    std::function<Status(MapStore&)> fn;
    std::promise<Status> result;
  };
  using Item = std::variant<PendingWrite, SyncCall>;

  StorageWriter(std::unique_ptr<MapStore> store, Options options);
  void Run();
  // Commits a group of batches in one transaction, falling back to one transaction per batch
  // when the merged write fails so a bad batch fails alone.
  void CommitGroup(std::vector<PendingWrite>& group);
  void Finish(PendingWrite& write, const Status& status, const WriteResult& result);
  bool OnWriterThread() const { return std::this_thread::get_id() == writer_id_; }

  std::unique_ptr<MapStore> store_;
  const Options options_;
  BoundedQueue<Item> queue_;
  // Set by Start before anything is queued (Submit, RunSync and Stop read it after).
  std::thread::id writer_id_;
  Status drain_status_;  // writer thread only until joined

  Mutex stop_mutex_;  // serialises Stop() calls
  std::thread thread_ SEMMAP_GUARDED_BY(stop_mutex_);
  bool stopped_ SEMMAP_GUARDED_BY(stop_mutex_) = false;
  Status stop_status_ SEMMAP_GUARDED_BY(stop_mutex_);
};

}  // namespace semmap
