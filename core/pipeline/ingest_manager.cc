#include "core/pipeline/ingest_manager.h"

#include <algorithm>
#include <cstdio>

#include "common/logging.h"

namespace semmap {

IngestManager::IngestManager(StorageWriter* writer, IngestOptions options,
                             std::shared_ptr<const BowVocabulary> vocabulary,
                             const ObjectCatalog* objects)
    : writer_(writer),
      options_(std::move(options)),
      vocabulary_(std::move(vocabulary)),
      objects_(objects) {}

IngestManager::~IngestManager() {
  BeginShutdown();
  Join();
}

StatusOr<std::shared_ptr<IngestSession>> IngestManager::Open(std::shared_ptr<IngestSink> sink) {
  std::lock_guard lock(mutex_);
  if (shutting_down_) return UnavailableError("the server is shutting down");
  ReapFinishedLocked();
  if (sessions_.size() >= options_.max_streams) {
    return ResourceExhaustedError(
        "the server is at its limit of " + std::to_string(options_.max_streams) +
        " concurrent ingest streams (semmapd --max-streams); try again when one has ended");
  }
  SEMMAP_ASSIGN_OR_RETURN(std::shared_ptr<IngestSession> session,
                          IngestSession::Start(std::move(sink), writer_, options_,
                                               [this](const SessionInfo& info, bool visual) {
                                                 return PipelinesFor(info, visual);
                                               }));
  sessions_.push_back(session);
  return session;
}

void IngestManager::BeginShutdown() {
  std::lock_guard lock(mutex_);
  shutting_down_ = true;
  for (auto& session : sessions_) session->Stop();
}

void IngestManager::Join() {
  std::vector<std::shared_ptr<IngestSession>> sessions;
  {
    std::lock_guard lock(mutex_);
    sessions.swap(sessions_);
  }
  // Destroying the last reference joins the worker; a reactor may still hold one briefly.
  sessions.clear();
  std::map<int64_t, MapPipelines> pipelines;
  {
    std::lock_guard lock(pipelines_mutex_);
    pipelines.swap(pipelines_);
  }
  // Back ends first: their last corrections still go to the layers.
  for (auto& [map_id, p] : pipelines) {
    if (p.backend) p.backend->Stop();  // drains, writes, joins
  }
  for (auto& [map_id, p] : pipelines) {
    if (p.layers) p.layers->Stop();    // rebuilds if needed, persists, joins
    if (p.objects) p.objects->Stop();  // decides the last keyframes, fuses, writes, joins
  }
}

StatusOr<MapPipelines> IngestManager::PipelinesFor(const SessionInfo& session, bool visual) {
  std::lock_guard lock(pipelines_mutex_);
  if (busy_maps_.count(session.map_id) != 0) {
    return UnavailableError("map '" + session.map_name +
                            "' is being changed by an administrative removal; try again shortly");
  }
  MapPipelines& p = pipelines_[session.map_id];
  // Each stage starts from what the map holds (earlier sessions, before a restart), read on the
  // stage's own thread ahead of its events, so neither this session nor the storage writer
  // waits for it.
  const StoreRestore from_store = Restore();
  if (!p.layers && options_.layers.enabled) {
    SEMMAP_ASSIGN_OR_RETURN(p.layers, MapLayerBuilder::Start(session.map_id, session.map_name,
                                                             options_.layers, writer_, from_store));
  }
  if (!p.objects && objects_ && options_.objects.enabled) {
    SEMMAP_ASSIGN_OR_RETURN(p.objects, ObjectMapper::Start(session.map_id, options_.objects,
                                                           objects_, writer_, from_store));
  }
  if (!p.backend && visual) {
    // What the map already holds joins the new graph, so new sessions close loops with it; this
    // session's own keyframes arrive as events (the read may already see its first ones).
    SlamRestore restore;
    restore.from_store = from_store;
    restore.skip_sessions = {session.id};
    SlamBackend::KeyframePoseListener listener;
    if (p.layers || p.objects) {
      listener = [layers = p.layers, objects = p.objects](std::vector<KeyframePose> poses,
                                                          bool correction) {
        // They refuse only once stopped (shutdown, a removal): nothing is left to build then,
        // but it is said, not dropped silently.
        const auto Report = [](const Status& status) {
          if (!status.ok()) LogDebug("keyframe poses not delivered: {}", status.ToString());
        };
        if (objects) Report(objects->SetKeyframePoses(poses, correction));
        if (layers) Report(layers->SetKeyframePoses(std::move(poses), correction));
      };
    }
    SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<SlamBackend> backend,
                            SlamBackend::Start(session.map_id, options_.slam, vocabulary_, writer_,
                                               std::move(restore), std::move(listener)));
    p.backend = std::move(backend);
  }
  return p;
}

StoreRestore IngestManager::Restore() const {
  return options_.open_reader ? StoreRestore::ThroughReader(options_.open_reader)
                              : StoreRestore::ThroughWriter();
}

namespace {

// Stops a map's pipelines: the back end first (its last corrections go to the others).
void StopPipelines(MapPipelines& p) {
  if (p.backend) p.backend->Stop();
  if (p.layers) p.layers->Stop();
  if (p.objects) p.objects->Stop();
}

}  // namespace

Status IngestManager::BeginMapChange(int64_t map_id, const std::string& map_name) {
  MapPipelines taken;
  {
    std::lock_guard lock(pipelines_mutex_);
    if (busy_maps_.count(map_id) != 0) {
      return FailedPreconditionError("map '" + map_name + "' is already being changed");
    }
    busy_maps_.insert(map_id);
  }
  {
    // A session that created its row but has not reached PipelinesFor yet fails there (busy).
    std::unique_lock lock(mutex_);
    ReapFinishedLocked();
    const bool streaming = std::any_of(sessions_.begin(), sessions_.end(),
                                       [&](const auto& s) { return s->map_id() == map_id; });
    lock.unlock();
    if (streaming) {
      EndMapChange(map_id);
      return FailedPreconditionError("map '" + map_name +
                                     "' has an ingest stream running; remove it after the stream "
                                     "has ended");
    }
  }
  {
    std::lock_guard lock(pipelines_mutex_);
    auto it = pipelines_.find(map_id);
    if (it != pipelines_.end()) {
      taken = std::move(it->second);
      pipelines_.erase(it);
    }
  }
  StopPipelines(taken);  // they persist what they hold; the removal then replaces it
  return OkStatus();
}

void IngestManager::EndMapChange(int64_t map_id) {
  std::lock_guard lock(pipelines_mutex_);
  busy_maps_.erase(map_id);
}

Status IngestManager::RebuildDerived(int64_t map_id, const std::string& map_name) {
  MapPipelines p;
  if (options_.layers.enabled) {
    SEMMAP_ASSIGN_OR_RETURN(
        p.layers, MapLayerBuilder::Start(map_id, map_name, options_.layers, writer_, Restore()));
    SEMMAP_RETURN_IF_ERROR(p.layers->Flush().WithContext("rebuilding the map layers"));
  }
  if (objects_ && options_.objects.enabled) {
    SEMMAP_ASSIGN_OR_RETURN(
        p.objects, ObjectMapper::Start(map_id, options_.objects, objects_, writer_, Restore()));
    SEMMAP_RETURN_IF_ERROR(p.objects->Flush().WithContext("re-placing the map's objects"));
  }
  // Kept for the map's next session (its back end is created then, from the store).
  std::lock_guard lock(pipelines_mutex_);
  pipelines_[map_id] = std::move(p);
  return OkStatus();
}

StatusOr<RemovedCounts> IngestManager::RemoveWhileChanging(
    int64_t map_id, const std::string& map, const CancelCheck& cancelled,
    const std::function<StatusOr<RemovedCounts>(MapStore&)>& remove, bool rebuild) {
  SEMMAP_RETURN_IF_ERROR(BeginMapChange(map_id, map));
  RemovedCounts counts;
  Status status = writer_->RunSync([&](MapStore& store) -> Status {
    SEMMAP_RETURN_IF_ERROR(CheckNotCancelled(cancelled));
    SEMMAP_ASSIGN_OR_RETURN(counts, remove(store));
    return OkStatus();
  });
  // Whether or not the removal committed, what is left is rebuilt from the store (a map that
  // was not removed gets fresh pipelines on its next use).
  Status rebuilt = rebuild || !status.ok() ? RebuildDerived(map_id, map) : OkStatus();
  EndMapChange(map_id);
  SEMMAP_RETURN_IF_ERROR(status);
  SEMMAP_RETURN_IF_ERROR(rebuilt);
  return counts;
}

StatusOr<RemovedCounts> IngestManager::RemoveSession(const std::string& map,
                                                     const std::string& session,
                                                     const CancelCheck& cancelled) {
  SessionInfo info;
  SEMMAP_RETURN_IF_ERROR(writer_->RunSync([&](MapStore& store) -> Status {
    SEMMAP_ASSIGN_OR_RETURN(info, store.GetSession(map, session));
    return OkStatus();
  }));
  SEMMAP_ASSIGN_OR_RETURN(
      RemovedCounts counts,
      RemoveWhileChanging(
          info.map_id, map, cancelled,
          [&](MapStore& store) { return store.RemoveSession(info.id); }, /*rebuild=*/true));
  LogInfo(
      "removed session '{}' of map '{}' ({} frames, {} keyframes); layers and objects "
      "rebuilt",
      session, map, counts.frames, counts.keyframes);
  return counts;
}

StatusOr<RemovedCounts> IngestManager::RemoveMap(const std::string& map,
                                                 const CancelCheck& cancelled) {
  MapInfo info;
  SEMMAP_RETURN_IF_ERROR(writer_->RunSync([&](MapStore& store) -> Status {
    SEMMAP_ASSIGN_OR_RETURN(info, store.GetMap(map));
    return OkStatus();
  }));
  SEMMAP_ASSIGN_OR_RETURN(
      RemovedCounts counts,
      RemoveWhileChanging(
          info.id, map, cancelled, [&](MapStore& store) { return store.RemoveMap(info.id); },
          /*rebuild=*/false));
  LogInfo("removed map '{}' ({} sessions, {} frames, {} keyframes)", map, counts.sessions,
          counts.frames, counts.keyframes);
  return counts;
}

size_t IngestManager::active_sessions() {
  std::lock_guard lock(mutex_);
  ReapFinishedLocked();
  return sessions_.size();
}

void IngestManager::ReapFinishedLocked() {
  sessions_.erase(std::remove_if(sessions_.begin(), sessions_.end(),
                                 [](const auto& s) { return s->finished(); }),
                  sessions_.end());
}

}  // namespace semmap
