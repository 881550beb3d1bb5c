#include "core/pipeline/commit_tracker.h"

#include <string>

namespace semmap {

void CommitTracker::Submitted() {
  MutexLock lock(mutex_);
  ++pending_;
}

void CommitTracker::SubmitFailed() {
  MutexLock lock(mutex_);
  --pending_;
  all_committed_.notify_all();
}

std::optional<uint64_t> CommitTracker::Committed(const Status& status, uint64_t seq,
                                                 double latency_ms) {
  MutexLock lock(mutex_);
  commit_ms_.Add(latency_ms);
  --pending_;
  if (status.ok()) {
    if (!durable_seq_ || seq > *durable_seq_) durable_seq_ = seq;
  } else if (error_.ok()) {
    error_ = status.WithContext("storing frame seq " + std::to_string(seq) + " failed");
  }
  all_committed_.notify_all();
  return durable_seq_;
}

void CommitTracker::WaitAll() {
  MutexLock lock(mutex_);
  while (pending_ != 0) all_committed_.wait(lock);
}

std::optional<uint64_t> CommitTracker::durable_seq() const {
  MutexLock lock(mutex_);
  return durable_seq_;
}

Status CommitTracker::error() const {
  MutexLock lock(mutex_);
  return error_;
}

LatencySummary CommitTracker::CommitLatency() const {
  MutexLock lock(mutex_);
  return commit_ms_.Summarize();
}

}  // namespace semmap
