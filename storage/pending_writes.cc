#include "storage/pending_writes.h"

namespace semmap {

void PendingWrites::Submit(WriteBatch batch) {
  {
    MutexLock lock(mutex_);
    ++pending_;
  }
  const Status submitted =
      writer_->Submit(std::move(batch), [this](const Status& status, const WriteResult&) {
        MutexLock lock(mutex_);
        if (!status.ok() && error_.ok()) error_ = status.WithContext(context_);
        --pending_;
        done_.notify_all();
      });
  if (!submitted.ok()) {
    MutexLock lock(mutex_);
    if (error_.ok()) error_ = submitted.WithContext(context_);
    --pending_;
    done_.notify_all();
  }
}

void PendingWrites::Record(const Status& status) {
  if (status.ok()) return;
  MutexLock lock(mutex_);
  if (error_.ok()) error_ = status.WithContext(context_);
}

void PendingWrites::Wait() {
  MutexLock lock(mutex_);
  while (pending_ != 0) done_.wait(lock);
}

Status PendingWrites::WaitAndTakeError() {
  MutexLock lock(mutex_);
  while (pending_ != 0) done_.wait(lock);
  Status error = error_;
  error_ = OkStatus();
  return error;
}

}  // namespace semmap
