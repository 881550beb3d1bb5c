// Owns the live ingest sessions of a server and what runs per map they stream into (the SLAM back
// end, the 3D layers): opens them, stops them all at shutdown and joins their worker threads off
// the network threads.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "server/ingest/ingest_options.h"
#include "server/ingest/ingest_session.h"

namespace semmap {

class IngestManager {
 public:
  // `vocabulary` (may be null: no place recognition) is shared by every map's back end;
  // `objects` (may be null: no object recognition) must outlive the manager.
  IngestManager(StorageWriter* writer, IngestOptions options,
                std::shared_ptr<const BowVocabulary> vocabulary = nullptr,
                const ObjectCatalog* objects = nullptr);
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
  StatusOr<MapPipelines> PipelinesFor(const SessionInfo& session, bool visual);

  StorageWriter* writer_;
  const IngestOptions options_;
  std::mutex mutex_;
  bool shutting_down_ = false;
  std::vector<std::shared_ptr<IngestSession>> sessions_;
  const std::shared_ptr<const BowVocabulary> vocabulary_;
  const ObjectCatalog* const objects_;
  std::mutex pipelines_mutex_;
  // They live as long as the server: a map's graph and layers keep growing across its sessions.
  std::map<int64_t, MapPipelines> pipelines_;
};

}  // namespace semmap
