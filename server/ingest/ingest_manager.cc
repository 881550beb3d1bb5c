#include "server/ingest/ingest_manager.h"

#include <algorithm>

namespace semmap {

IngestManager::IngestManager(StorageWriter* writer, IngestOptions options,
                             std::shared_ptr<const BowVocabulary> vocabulary)
    : writer_(writer), options_(std::move(options)), vocabulary_(std::move(vocabulary)) {}

IngestManager::~IngestManager() {
  BeginShutdown();
  Join();
}

StatusOr<std::shared_ptr<IngestSession>> IngestManager::Open(std::shared_ptr<IngestSink> sink) {
  std::lock_guard lock(mutex_);
  if (shutting_down_) return UnavailableError("the server is shutting down");
  ReapFinishedLocked();
  auto session = std::make_shared<IngestSession>(
      std::move(sink), writer_, options_, [this](int64_t map_id) { return BackendFor(map_id); });
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
  std::map<int64_t, std::shared_ptr<SlamBackend>> backends;
  {
    std::lock_guard lock(backends_mutex_);
    backends.swap(backends_);
  }
  for (auto& [map_id, backend] : backends) backend->Stop();  // drains, writes, joins
}

StatusOr<std::shared_ptr<SlamBackend>> IngestManager::BackendFor(int64_t map_id) {
  std::lock_guard lock(backends_mutex_);
  auto it = backends_.find(map_id);
  if (it != backends_.end()) return it->second;
  // What the map already holds (earlier sessions, before a restart) joins the new graph, so new
  // sessions close loops with it. Read on the writer's thread: consistent with queued writes.
  MapSnapshot snapshot;
  SEMMAP_RETURN_IF_ERROR(writer_->RunSync([&](MapStore& store) -> Status {
    SEMMAP_ASSIGN_OR_RETURN(snapshot, ReadMapSnapshot(store, map_id));
    return OkStatus();
  }));
  SEMMAP_ASSIGN_OR_RETURN(
      std::unique_ptr<SlamBackend> backend,
      SlamBackend::Start(map_id, options_.slam, vocabulary_, writer_, &snapshot));
  std::shared_ptr<SlamBackend> shared = std::move(backend);
  backends_.emplace(map_id, shared);
  return shared;
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
