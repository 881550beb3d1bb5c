// Owns the live ingest sessions of a server and what runs per map they stream into (a
// MapPipeline: the SLAM back end, the layers, the objects): opens them, keeps at most
// max_open_maps pipelines (RESOURCE_EXHAUSTED beyond) and evicts idle ones beyond
// max_idle_maps (their state persists; the next session restores it), stops them all at
// shutdown. It is the only owner of the sessions: transports get an IngestSessionHandle handle, and
// a reaper thread of the manager's destroys (joins) each session once it has finished, never a
// network thread and never the session's own.
#pragma once

#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "common/cancel_check.h"
#include "common/thread_annotations.h"
#include "core/pipeline/ingest_options.h"
#include "core/pipeline/ingest_session.h"
#include "core/pipeline/ingest_session_handle.h"
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

  // A new session reporting to `sink`, fed through the returned handle. UNAVAILABLE once
  // shutdown has begun; RESOURCE_EXHAUSTED at options.max_streams live streams or when the
  // stream's threads cannot be started.
  StatusOr<std::shared_ptr<IngestSessionHandle>> Open(std::shared_ptr<IngestSink> sink)
      SEMMAP_EXCLUDES(mutex_);

  // Administration; `cancelled` is asked on the writer thread right before the removal commits.
  // Removes a session; the map's layers and object instances are rebuilt from what is left
  // before this returns, and its SLAM graph is reloaded by the next session. NOT_FOUND for an
  // unknown map or session, FAILED_PRECONDITION while a stream ingests into the map.
  StatusOr<RemovedCounts> RemoveSession(const std::string& map, const std::string& session,
                                        const CancelCheck& cancelled);
  // Removes a map with all its sessions. Same errors.
  StatusOr<RemovedCounts> RemoveMap(const std::string& map, const CancelCheck& cancelled);
  // Every session stores what it has queued and finishes with UNAVAILABLE; no new sessions.
  void BeginShutdown() SEMMAP_EXCLUDES(mutex_);
  // Waits until every session has finished and been destroyed, then stops every map's
  // pipelines (call after BeginShutdown).
  void Join() SEMMAP_EXCLUDES(mutex_, pipelines_mutex_);
  // Sessions that have not finished yet.
  size_t active_sessions() SEMMAP_EXCLUDES(mutex_);
  // Sessions not yet destroyed (finished ones until the reaper has joined them).
  size_t owned_sessions() SEMMAP_EXCLUDES(mutex_);
  size_t open_maps() SEMMAP_EXCLUDES(pipelines_mutex_);

 private:
  struct LiveSession {
    std::unique_ptr<IngestSession> session;
    std::shared_ptr<IngestSessionHandle> stream;
  };
  // The reaper thread: destroys finished sessions (their threads are joined here).
  void Reap() SEMMAP_EXCLUDES(mutex_);
  StatusOr<std::shared_ptr<MapPipeline>> PipelineFor(const SessionInfo& session, bool visual)
      SEMMAP_EXCLUDES(pipelines_mutex_);
  // Stops and drops idle pipelines (no session holds them), least recently used first, until
  // at most `keep_idle` idle ones and `max_open` in all are left (or none is idle). Called with
  // pipelines_mutex_ held.
  void EvictIdleLocked(size_t keep_idle, size_t max_open) SEMMAP_REQUIRES(pipelines_mutex_);
  // How stages read what a map holds: a read connection of their own when the options give
  // one, else through the writer.
  StoreRestore Restore() const;
  // Marks the map busy (new sessions on it fail UNAVAILABLE), checks no stream ingests into it,
  // and stops and drops its pipelines. FAILED_PRECONDITION when a stream is live.
  Status BeginMapChange(int64_t map_id, const std::string& map_name)
      SEMMAP_EXCLUDES(mutex_, pipelines_mutex_);
  void EndMapChange(int64_t map_id) SEMMAP_EXCLUDES(pipelines_mutex_);
  // Rebuilds a map's layers and object instances from the store (after a session removal).
  Status RebuildDerived(int64_t map_id, const std::string& map_name)
      SEMMAP_EXCLUDES(pipelines_mutex_);
  // BeginMapChange, `remove` on the writer thread after `cancelled`, the rebuild, EndMapChange.
  StatusOr<RemovedCounts> RemoveWhileChanging(
      int64_t map_id, const std::string& map, const CancelCheck& cancelled,
      const std::function<StatusOr<RemovedCounts>(MapStore&)>& remove, bool rebuild);

  StorageWriter* writer_;
  const IngestOptions options_;
  Mutex mutex_;
  std::condition_variable_any sessions_changed_;  // a session finished or was destroyed
  bool shutting_down_ SEMMAP_GUARDED_BY(mutex_) = false;
  uint64_t next_session_ SEMMAP_GUARDED_BY(mutex_) = 0;
  std::map<uint64_t, LiveSession> sessions_ SEMMAP_GUARDED_BY(mutex_);
  std::vector<uint64_t> finished_ SEMMAP_GUARDED_BY(mutex_);  // for the reaper
  bool stop_reaper_ SEMMAP_GUARDED_BY(mutex_) = false;
  std::thread reaper_;  // started by the first Open (under mutex_), joined by Join
  const std::shared_ptr<const BowVocabulary> vocabulary_;
  const ObjectCatalog* const objects_;
  struct OpenMap {
    std::shared_ptr<MapPipeline> pipeline;  // sessions hold references while they stream
    uint64_t last_used = 0;                 // a counter, for least-recently-used eviction
  };
  Mutex pipelines_mutex_;
  std::map<int64_t, OpenMap> pipelines_ SEMMAP_GUARDED_BY(pipelines_mutex_);
  uint64_t use_counter_ SEMMAP_GUARDED_BY(pipelines_mutex_) = 0;
  // Being changed by an administrative removal.
  std::set<int64_t> busy_maps_ SEMMAP_GUARDED_BY(pipelines_mutex_);
};

}  // namespace semmap
