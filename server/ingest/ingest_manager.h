// Owns the live ingest sessions of a server: opens them, stops them all at shutdown and joins
// their worker threads off the network threads.
#pragma once

#include <memory>
#include <mutex>
#include <vector>

#include "server/ingest/ingest_options.h"
#include "server/ingest/ingest_session.h"

namespace semmap {

class IngestManager {
 public:
  IngestManager(StorageWriter* writer, IngestOptions options);
  ~IngestManager();

  // UNAVAILABLE once shutdown has begun.
  StatusOr<std::shared_ptr<IngestSession>> Open(std::shared_ptr<IngestSink> sink);
  // Every session stores what it has queued and finishes with UNAVAILABLE; no new sessions.
  void BeginShutdown();
  // Waits for every session's worker to finish (call after BeginShutdown).
  void Join();
  size_t active_sessions();

 private:
  void ReapFinishedLocked();

  StorageWriter* writer_;
  const IngestOptions options_;
  std::mutex mutex_;
  bool shutting_down_ = false;
  std::vector<std::shared_ptr<IngestSession>> sessions_;
};

}  // namespace semmap
