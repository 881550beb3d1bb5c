#include "core/pipeline/ingest_session_handle.h"

#include "core/pipeline/ingest_session.h"

namespace semmap {

bool IngestSessionHandle::TryEnqueue(IngestMessage& message) {
  MutexLock lock(mutex_);
  return session_ != nullptr && session_->TryEnqueue(message);
}

bool IngestSessionHandle::HasRoom() {
  MutexLock lock(mutex_);
  return session_ != nullptr && session_->HasRoom();
}

void IngestSessionHandle::Cancel(bool deadline_passed) {
  MutexLock lock(mutex_);
  if (session_ != nullptr) session_->Cancel(deadline_passed);
}

void IngestSessionHandle::Stop() {
  MutexLock lock(mutex_);
  if (session_ != nullptr) session_->Stop();
}

void IngestSessionHandle::Release() {
  MutexLock lock(mutex_);
  session_ = nullptr;
}

}  // namespace semmap
