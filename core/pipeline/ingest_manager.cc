#include "core/pipeline/ingest_manager.h"

#include <algorithm>
#include <cstdio>

#include "common/logging.h"
#include "common/memory_trim.h"
#include "common/thread_launcher.h"
#include "common/thread_priority.h"

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

StatusOr<std::shared_ptr<IngestSessionHandle>> IngestManager::Open(
    std::shared_ptr<IngestSink> sink) {
  MutexLock lock(mutex_);
  if (shutting_down_) return UnavailableError("the server is shutting down");
  const size_t live =
      static_cast<size_t>(std::count_if(sessions_.begin(), sessions_.end(), [](const auto& s) {
        return !s.second.session->finished();
      }));
  if (live >= options_.max_streams) {
    return ResourceExhaustedError(
        "the server is at its limit of " + std::to_string(options_.max_streams) +
        " concurrent ingest streams (semmapd --max-streams); try again when one has ended");
  }
  // The server's own thread (options_.launch_thread is for the clients' threads).
  if (!reaper_.joinable()) {
    StatusOr<std::thread> reaper = LaunchThread([this] {
      NameCurrentThread("session-reaper");
      Reap();
    });
    if (!reaper.ok()) return reaper.status();
    reaper_ = std::move(reaper).value();
  }
  const uint64_t id = ++next_session_;
  auto on_finished = [this, id] {
    MutexLock finished_lock(mutex_);
    finished_.push_back(id);
    sessions_changed_.notify_all();
  };
  StatusOr<std::unique_ptr<IngestSession>> started = IngestSession::Start(
      std::move(sink), writer_, options_,
      [this](const SessionInfo& info, bool visual) { return PipelineFor(info, visual); },
      std::move(on_finished));
  if (!started.ok()) return started.status();
  std::unique_ptr<IngestSession> session = std::move(started).value();
  auto stream = std::make_shared<IngestSessionHandle>(session.get());
  sessions_.emplace(id, LiveSession{std::move(session), stream});
  return stream;
}

void IngestManager::Reap() {
  MutexLock lock(mutex_);
  for (;;) {
    while (finished_.empty() && !stop_reaper_) sessions_changed_.wait(lock);
    if (finished_.empty()) return;  // stop_reaper_: Join saw every session destroyed
    std::vector<LiveSession> done;
    for (const uint64_t id : finished_) {
      auto it = sessions_.find(id);
      if (it == sessions_.end()) continue;
      done.push_back(std::move(it->second));
      sessions_.erase(it);
    }
    finished_.clear();
    lock.unlock();
    for (LiveSession& live : done) {
      live.stream->Release();  // the transport's later calls do nothing
      live.session.reset();    // joins its threads; they have finished
    }
    done.clear();
    lock.lock();
    sessions_changed_.notify_all();
  }
}

void IngestManager::BeginShutdown() {
  MutexLock lock(mutex_);
  shutting_down_ = true;
  for (auto& [id, live] : sessions_) live.session->Stop();
}

void IngestManager::Join() {
  {
    MutexLock lock(mutex_);
    // Every session finishes after BeginShutdown (it stores what it has queued first).
    while (!sessions_.empty()) sessions_changed_.wait(lock);
    stop_reaper_ = true;
    sessions_changed_.notify_all();
  }
  if (reaper_.joinable()) reaper_.join();
  std::map<int64_t, OpenMap> maps;
  {
    MutexLock lock(pipelines_mutex_);
    maps.swap(pipelines_);
  }
  // Each stops its back end first: the last corrections still go to the layers and objects.
  for (auto& [map_id, open] : maps) open.pipeline->Stop();
}

StatusOr<std::shared_ptr<MapPipeline>> IngestManager::PipelineFor(const SessionInfo& session,
                                                                  bool visual) {
  MutexLock lock(pipelines_mutex_);
  if (busy_maps_.count(session.map_id) != 0) {
    return UnavailableError("map '" + session.map_name +
                            "' is being changed by an administrative removal; try again shortly");
  }
  auto it = pipelines_.find(session.map_id);
  if (it == pipelines_.end()) {
    // Room for one more: idle maps go first (their state is persisted; a later session
    // restores it), then the limit on open maps.
    EvictIdleLocked(options_.max_idle_maps, options_.max_open_maps - 1);
    if (pipelines_.size() >= options_.max_open_maps) {
      return ResourceExhaustedError(
          "the server has " + std::to_string(pipelines_.size()) +
          " maps open with sessions streaming into each (semmapd --max-open-maps " +
          std::to_string(options_.max_open_maps) + "); try again when one has ended");
    }
    // Each stage starts from what the map holds (earlier sessions, before a restart), read on
    // its own thread ahead of its events, so neither this session nor the writer waits.
    SEMMAP_ASSIGN_OR_RETURN(
        std::unique_ptr<MapPipeline> created,
        MakeMapPipeline(session.map_id, session.map_name, options_, writer_, objects_, Restore()));
    it = pipelines_.emplace(session.map_id, OpenMap{std::move(created), 0}).first;
  }
  OpenMap& open = it->second;
  open.last_used = ++use_counter_;
  if (visual && !open.pipeline->backend()) {
    // What the map already holds joins the new graph, so new sessions close loops with it; this
    // session's own keyframes arrive as events (the read may already see its first ones).
    SlamRestore restore;
    restore.from_store = Restore();
    restore.skip_sessions = {session.id};
    SEMMAP_RETURN_IF_ERROR(
        open.pipeline->EnsureBackend(options_.slam, vocabulary_, writer_, std::move(restore))
            .status());
  }
  std::shared_ptr<MapPipeline> pipeline = open.pipeline;  // held: not idle
  // Idle maps beyond the ones kept warm for their next session are released.
  EvictIdleLocked(options_.max_idle_maps, options_.max_open_maps);
  return pipeline;
}

void IngestManager::EvictIdleLocked(size_t keep_idle, size_t max_open) {
  for (;;) {
    std::vector<std::map<int64_t, OpenMap>::iterator> idle;
    for (auto it = pipelines_.begin(); it != pipelines_.end(); ++it) {
      if (it->second.pipeline.use_count() == 1) idle.push_back(it);
    }
    if (idle.empty() || (idle.size() <= keep_idle && pipelines_.size() <= max_open)) return;
    auto oldest = *std::min_element(idle.begin(), idle.end(), [](const auto& a, const auto& b) {
      return a->second.last_used < b->second.last_used;
    });
    // Persists what it holds and joins its threads (under the lock: a session for this map
    // must not restore before the blobs are written).
    const std::string name = oldest->second.pipeline->map_name();
    const size_t before = ResidentBytes();
    oldest->second.pipeline->Stop();
    pipelines_.erase(oldest);
    ReleaseFreedMemory();  // what the map held (clouds, features, trees) leaves the process
    LogInfo("map '{}': released its idle pipeline ({} maps open); resident memory {} -> {} MB",
            name, pipelines_.size(), before >> 20, ResidentBytes() >> 20);
  }
}

StoreRestore IngestManager::Restore() const {
  return options_.open_reader ? StoreRestore::ThroughReader(options_.open_reader)
                              : StoreRestore::ThroughWriter();
}

Status IngestManager::BeginMapChange(int64_t map_id, const std::string& map_name) {
  std::shared_ptr<MapPipeline> taken;
  {
    MutexLock lock(pipelines_mutex_);
    if (busy_maps_.count(map_id) != 0) {
      return FailedPreconditionError("map '" + map_name + "' is already being changed");
    }
    busy_maps_.insert(map_id);
  }
  {
    // A session that created its row but has not reached PipelineFor yet fails there (busy).
    bool streaming = false;
    {
      MutexLock lock(mutex_);
      streaming = std::any_of(sessions_.begin(), sessions_.end(), [&](const auto& s) {
        return !s.second.session->finished() && s.second.session->map_id() == map_id;
      });
    }
    if (streaming) {
      EndMapChange(map_id);
      return FailedPreconditionError("map '" + map_name +
                                     "' has an ingest stream running; remove it after the stream "
                                     "has ended");
    }
  }
  {
    MutexLock lock(pipelines_mutex_);
    auto it = pipelines_.find(map_id);
    if (it != pipelines_.end()) {
      taken = std::move(it->second.pipeline);
      pipelines_.erase(it);
    }
  }
  if (taken) taken->Stop();  // it persists what it holds; the removal then replaces it
  return OkStatus();
}

void IngestManager::EndMapChange(int64_t map_id) {
  MutexLock lock(pipelines_mutex_);
  busy_maps_.erase(map_id);
}

Status IngestManager::RebuildDerived(int64_t map_id, const std::string& map_name) {
  SEMMAP_ASSIGN_OR_RETURN(
      std::unique_ptr<MapPipeline> rebuilt,
      MakeMapPipeline(map_id, map_name, options_, writer_, objects_, Restore()));
  SEMMAP_RETURN_IF_ERROR(
      rebuilt->FlushConsumers().WithContext("rebuilding the map's layers and objects"));
  // Kept for the map's next session (its back end is created then, from the store).
  MutexLock lock(pipelines_mutex_);
  pipelines_[map_id] = OpenMap{std::move(rebuilt), ++use_counter_};
  EvictIdleLocked(options_.max_idle_maps, options_.max_open_maps);
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

size_t IngestManager::open_maps() {
  MutexLock lock(pipelines_mutex_);
  return pipelines_.size();
}

size_t IngestManager::active_sessions() {
  MutexLock lock(mutex_);
  return static_cast<size_t>(std::count_if(sessions_.begin(), sessions_.end(), [](const auto& s) {
    return !s.second.session->finished();
  }));
}

size_t IngestManager::owned_sessions() {
  MutexLock lock(mutex_);
  return sessions_.size();
}

}  // namespace semmap
