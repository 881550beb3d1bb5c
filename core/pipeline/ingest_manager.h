// Owns the live ingest sessions of a server and what runs per map they stream into (a
// MapPipeline: the SLAM back end, the layers, the objects): opens them, keeps at most
// max_open_maps pipelines (RESOURCE_EXHAUSTED beyond) and evicts idle ones beyond
// max_idle_maps (their state persists; the next session restores it), stops them all at
// shutdown and joins their worker threads off the network threads.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "common/cancel_check.h"
#include "core/pipeline/ingest_options.h"
#include "core/pipeline/ingest_session.h"
#include "core/pipeline/map_pipeline.h"

namespace semmap {

class IngestManager {
 public:
  // `vocabulary` (may be null: no place recognition) is shared by every map's back end;
  // `objects` (may be null: no object recognition) must outlive the manager.
  IngestManager(StorageWriter* writer, IngestOptions options,
                std::shared_ptr<const BowVocabulary> vocabulary = nullptr,
                const ObjectCatalog* objects = nullptr);
  ~IngestManager();

  // UNAVAILABLE once shutdown has begun; RESOURCE_EXHAUSTED at options.max_streams live streams
  // or when the stream's threads cannot be started.
  StatusOr<std::shared_ptr<IngestSession>> Open(std::shared_ptr<IngestSink> sink);

  // Administration; `cancelled` is asked on the writer thread right before the removal commits.
  // Removes a session; the map's layers and object instances are rebuilt from what is left
  // before this returns, and its SLAM graph is reloaded by the next session. NOT_FOUND for an
  // unknown map or session, FAILED_PRECONDITION while a stream ingests into the map.
  StatusOr<RemovedCounts> RemoveSession(const std::string& map, const std::string& session,
                                        const CancelCheck& cancelled);
  // Removes a map with all its sessions. Same errors.
  StatusOr<RemovedCounts> RemoveMap(const std::string& map, const CancelCheck& cancelled);
  // Every session stores what it has queued and finishes with UNAVAILABLE; no new sessions.
  void BeginShutdown();
  // Waits for every session's worker to finish (call after BeginShutdown).
  void Join();
  size_t active_sessions();
  size_t open_maps();

 private:
  void ReapFinishedLocked();
  StatusOr<std::shared_ptr<MapPipeline>> PipelineFor(const SessionInfo& session, bool visual);
  // Stops and drops idle pipelines (no session holds them), least recently used first, until
  // at most `keep_idle` idle ones and `max_open` in all are left (or none is idle). Called with
  // pipelines_mutex_ held.
  void EvictIdleLocked(size_t keep_idle, size_t max_open);
  // How stages read what a map holds: a read connection of their own when the options give
  // one, else through the writer.
  StoreRestore Restore() const;
  // Marks the map busy (new sessions on it fail UNAVAILABLE), checks no stream ingests into it,
  // and stops and drops its pipelines. FAILED_PRECONDITION when a stream is live.
  Status BeginMapChange(int64_t map_id, const std::string& map_name);
  void EndMapChange(int64_t map_id);
  // Rebuilds a map's layers and object instances from the store (after a session removal).
  Status RebuildDerived(int64_t map_id, const std::string& map_name);
  // BeginMapChange, `remove` on the writer thread after `cancelled`, the rebuild, EndMapChange.
  StatusOr<RemovedCounts> RemoveWhileChanging(
      int64_t map_id, const std::string& map, const CancelCheck& cancelled,
      const std::function<StatusOr<RemovedCounts>(MapStore&)>& remove, bool rebuild);

  StorageWriter* writer_;
  const IngestOptions options_;
  std::mutex mutex_;
  bool shutting_down_ = false;
  std::vector<std::shared_ptr<IngestSession>> sessions_;
  const std::shared_ptr<const BowVocabulary> vocabulary_;
  const ObjectCatalog* const objects_;
  struct OpenMap {
    std::shared_ptr<MapPipeline> pipeline;  // sessions hold references while they stream
    uint64_t last_used = 0;                 // a counter, for least-recently-used eviction
  };
  std::mutex pipelines_mutex_;
  std::map<int64_t, OpenMap> pipelines_;
  uint64_t use_counter_ = 0;
  std::set<int64_t> busy_maps_;  // being changed by an administrative removal
};

}  // namespace semmap
