// What a pipeline stage needs from the storage writer to offer a Flush(): it submits batches
// through this, which counts those not yet committed and keeps the first error, so the stage
// can wait until everything it submitted is durable and report what failed.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <string>

#include "common/status.h"
#include "common/thread_annotations.h"
#include "storage/storage_writer.h"

namespace semmap {

class PendingWrites {
 public:
  // `context` prefixes recorded errors ("slam back end"). `writer` must outlive this.
  PendingWrites(StorageWriter* writer, std::string context)
      : writer_(writer), context_(std::move(context)) {}
  PendingWrites(const PendingWrites&) = delete;
  PendingWrites& operator=(const PendingWrites&) = delete;

  // Never blocks longer than StorageWriter::Submit; a refused or failed write is recorded.
  void Submit(WriteBatch batch) SEMMAP_EXCLUDES(mutex_);
  // Keeps the first error until TakeError.
  void Record(const Status& status) SEMMAP_EXCLUDES(mutex_);
  // Waits until every submitted batch is committed or failed.
  void Wait() SEMMAP_EXCLUDES(mutex_);
  // Wait(), then returns the first error since the last call and forgets it.
  Status WaitAndTakeError() SEMMAP_EXCLUDES(mutex_);

 private:
  StorageWriter* const writer_;
  const std::string context_;
  Mutex mutex_;
  std::condition_variable_any done_;  // waits on a MutexLock of mutex_
  size_t pending_ SEMMAP_GUARDED_BY(mutex_) = 0;
  Status error_ SEMMAP_GUARDED_BY(mutex_);
};

}  // namespace semmap
