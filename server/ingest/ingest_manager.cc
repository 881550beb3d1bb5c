#include "server/ingest/ingest_manager.h"

#include <algorithm>

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
  auto session = std::make_shared<IngestSession>(
      std::move(sink), writer_, options_,
      [this](const SessionInfo& info, bool visual) { return PipelinesFor(info, visual); });
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
  MapPipelines& p = pipelines_[session.map_id];
  if (!p.layers && options_.layers.enabled) {
    // Started with the map's stored keyframes (earlier sessions, before a restart), read on the
    // layers' own thread.
    SEMMAP_ASSIGN_OR_RETURN(
        p.layers, MapLayerBuilder::Start(session.map_id, session.map_name, options_.layers, writer_,
                                         /*restore=*/true));
  }
  if (!p.objects && objects_ && options_.objects.enabled) {
    SEMMAP_ASSIGN_OR_RETURN(p.objects, ObjectMapper::Start(session.map_id, options_.objects,
                                                           objects_, writer_, /*restore=*/true));
  }
  if (!p.backend && visual) {
    // What the map already holds joins the new graph, so new sessions close loops with it. Read
    // on the writer's thread: consistent with queued writes.
    MapSnapshot snapshot;
    SEMMAP_RETURN_IF_ERROR(writer_->RunSync([&](MapStore& store) -> Status {
      SEMMAP_ASSIGN_OR_RETURN(snapshot, ReadMapSnapshot(store, session.map_id));
      return OkStatus();
    }));
    SlamBackend::KeyframePoseListener listener;
    if (p.layers || p.objects) {
      listener = [layers = p.layers, objects = p.objects](std::vector<KeyframePose> poses,
                                                          bool correction) {
        // UNAVAILABLE only once they stopped, at shutdown: nothing left to build.
        if (objects) (void)objects->SetKeyframePoses(poses, correction);
        if (layers) (void)layers->SetKeyframePoses(std::move(poses), correction);
      };
    }
    SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<SlamBackend> backend,
                            SlamBackend::Start(session.map_id, options_.slam, vocabulary_, writer_,
                                               &snapshot, std::move(listener)));
    p.backend = std::move(backend);
  }
  return p;
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
