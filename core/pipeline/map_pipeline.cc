#include "core/pipeline/map_pipeline.h"

#include <utility>

#include "common/logging.h"

namespace semmap {

MapPipeline::MapPipeline(int64_t map_id, std::string map_name)
    : map_id_(map_id), map_name_(std::move(map_name)) {}

MapPipeline::~MapPipeline() { Stop(); }

void MapPipeline::AddConsumer(std::unique_ptr<MapConsumer> consumer) {
  consumers_.push_back(std::move(consumer));
}

StatusOr<SlamBackend*> MapPipeline::EnsureBackend(const SlamBackendOptions& options,
                                                  std::shared_ptr<const BowVocabulary> vocabulary,
                                                  StorageWriter* writer, SlamRestore restore) {
  std::lock_guard lock(backend_mutex_);
  if (backend_) return backend_.get();
  SlamBackend::KeyframePoseListener listener;
  if (!consumers_.empty()) {
    // Runs on the back end's thread; the back end stops before the consumers do.
    listener = [this](std::vector<KeyframePose> poses, bool correction) {
      PublishPoses(std::move(poses), correction);
    };
  }
  SEMMAP_ASSIGN_OR_RETURN(backend_,
                          SlamBackend::Start(map_id_, options, std::move(vocabulary), writer,
                                             std::move(restore), std::move(listener)));
  return backend_.get();
}

SlamBackend* MapPipeline::backend() const {
  std::lock_guard lock(backend_mutex_);
  return backend_.get();
}

void MapPipeline::PublishPoses(std::vector<KeyframePose> poses, bool correction) {
  const auto deliver = [&](MapConsumer& consumer, std::vector<KeyframePose> list) {
    const Status status = consumer.OnKeyframePoses(std::move(list), correction);
    // A consumer refuses only once stopped (shutdown, a removal): nothing is left to build.
    if (!status.ok()) {
      LogDebug("{}: keyframe poses not delivered: {}", consumer.name(), status.ToString());
    }
  };
  if (consumers_.empty()) return;
  // Every consumer but the last gets a copy; the last takes the list.
  for (size_t i = 0; i + 1 < consumers_.size(); ++i) deliver(*consumers_[i], poses);
  deliver(*consumers_.back(), std::move(poses));
}

Status MapPipeline::PublishKeyframe(const MapKeyframe& keyframe) {
  Status first;
  for (const auto& consumer : consumers_) {
    const Status status = consumer->OnKeyframe(keyframe);
    if (first.ok() && !status.ok()) first = status;
  }
  return first;
}

Status MapPipeline::FinishSession(int64_t session_id, MapSessionReport* report) {
  Status first;
  if (SlamBackend* b = backend()) {
    b->UnregisterSession(session_id);
    first = b->Drain();
    SlamBackendStats stats = b->stats();
    for (const LoopClosureInfo& loop : stats.loops) {
      if (loop.query_session_id == session_id) ++report->loop_closures;
    }
    report->stages = {stats.keyframe_ms, stats.optimise_ms, stats.local_ba_ms};
    if (stats.final_ba_ms.count > 0) report->stages.push_back(stats.final_ba_ms);
    report->backend = std::move(stats);
  }
  // After the back end's drain: its last corrections are queued to the consumers already.
  for (const auto& consumer : consumers_) {
    Status ended = consumer->OnSessionEnd(session_id);
    const Status flushed = ended.ok() ? consumer->Flush() : ended;
    if (first.ok() && !flushed.ok()) first = flushed;
    LogInfo("map '{}' {}: {}", map_name_, consumer->kind(), consumer->Summary());
    for (LatencySummary& stage : consumer->Latencies()) report->stages.push_back(std::move(stage));
  }
  return first;
}

Status MapPipeline::FlushConsumers() {
  Status first;
  for (const auto& consumer : consumers_) {
    const Status flushed = consumer->Flush();
    if (first.ok() && !flushed.ok()) first = flushed.WithContext(consumer->name());
  }
  return first;
}

void MapPipeline::Stop() {
  std::lock_guard stop(stop_mutex_);
  if (stopped_) return;
  stopped_ = true;
  if (SlamBackend* b = backend()) b->Stop();  // drains, writes, joins
  for (const auto& consumer : consumers_) consumer->Stop();
}

StatusOr<std::unique_ptr<MapPipeline>> MakeMapPipeline(int64_t map_id, const std::string& map_name,
                                                       const IngestOptions& options,
                                                       StorageWriter* writer,
                                                       const ObjectCatalog* objects,
                                                       const StoreRestore& restore) {
  auto pipeline = std::make_unique<MapPipeline>(map_id, map_name);
  if (objects && options.objects.enabled) {
    SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<ObjectMapper> mapper,
                            ObjectMapper::Start(map_id, options.objects, objects, writer, restore));
    pipeline->AddConsumer(std::make_unique<ObjectsConsumer>(std::move(mapper)));
  }
  if (options.layers.enabled) {
    SEMMAP_ASSIGN_OR_RETURN(
        std::unique_ptr<MapLayerBuilder> layers,
        MapLayerBuilder::Start(map_id, map_name, options.layers, writer, restore));
    pipeline->AddConsumer(std::make_unique<LayersConsumer>(std::move(layers)));
  }
  return pipeline;
}

}  // namespace semmap
