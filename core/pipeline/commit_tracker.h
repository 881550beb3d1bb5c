// A session's writes in flight to the storage writer: how many are pending, the highest seq
// committed (the durable_seq of acks), the first write that failed, and how long commits took.
// The worker thread submits and waits; the writer thread reports commits.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <optional>

#include "common/latency_stats.h"
#include "common/status.h"
#include "common/thread_annotations.h"

namespace semmap {

class CommitTracker {
 public:
  // A batch is about to be submitted.
  void Submitted() SEMMAP_EXCLUDES(mutex_);
  // The writer refused it: it will never commit.
  void SubmitFailed() SEMMAP_EXCLUDES(mutex_);
  // The writer committed (or failed to commit) the batch of frame `seq`; returns the durable
  // seq after it.
  std::optional<uint64_t> Committed(const Status& status, uint64_t seq, double latency_ms)
      SEMMAP_EXCLUDES(mutex_);
  // Blocks until every submitted batch committed or failed.
  void WaitAll() SEMMAP_EXCLUDES(mutex_);

  std::optional<uint64_t> durable_seq() const SEMMAP_EXCLUDES(mutex_);
  // The first failed commit, naming its frame; OK while none failed.
  Status error() const SEMMAP_EXCLUDES(mutex_);
  LatencySummary CommitLatency() const SEMMAP_EXCLUDES(mutex_);

 private:
  mutable Mutex mutex_;
  std::condition_variable_any all_committed_;
  size_t pending_ SEMMAP_GUARDED_BY(mutex_) = 0;
  std::optional<uint64_t> durable_seq_ SEMMAP_GUARDED_BY(mutex_);
  Status error_ SEMMAP_GUARDED_BY(mutex_);
  LatencyStats commit_ms_ SEMMAP_GUARDED_BY(mutex_){"storage_commit"};
};

}  // namespace semmap
