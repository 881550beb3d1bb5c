#include "storage/pending_writes.h"

namespace semmap {

void PendingWrites::Submit(WriteBatch batch) {
  {
    std::lock_guard lock(mutex_);
    ++pending_;
  }
  const Status submitted =
      writer_->Submit(std::move(batch), [this](const Status& status, const WriteResult&) {
        std::lock_guard lock(mutex_);
        if (!status.ok() && error_.ok()) error_ = status.WithContext(context_);
        --pending_;
        done_.notify_all();
      });
  if (!submitted.ok()) {
    std::lock_guard lock(mutex_);
    if (error_.ok()) error_ = submitted.WithContext(context_);
    --pending_;
    done_.notify_all();
  }
}

void PendingWrites::Record(const Status& status) {
  if (status.ok()) return;
  std::lock_guard lock(mutex_);
  if (error_.ok()) error_ = status.WithContext(context_);
}

void PendingWrites::Wait() {
  std::unique_lock lock(mutex_);
  done_.wait(lock, [&] { return pending_ == 0; });
}

Status PendingWrites::WaitAndTakeError() {
  std::unique_lock lock(mutex_);
  done_.wait(lock, [&] { return pending_ == 0; });
  Status error = error_;
  error_ = OkStatus();
  return error;
}

}  // namespace semmap
