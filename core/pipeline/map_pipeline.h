// Everything that runs for one map, shared by the sessions streaming into it: the SLAM back end
// of visual sessions (started with the first of them) and a list of consumers of keyframes and
// keyframe poses (map_consumers.h: the layers, the objects). Sessions publish each keyframe
// once; the back end's pose events reach every consumer. A new consumer (MONO depth, bundle
// adjustment, an exporter) is one AddConsumer call in MakeMapPipeline, not a new call in every
// session. Stages restore what the map holds on their own threads (StoreRestore).
//
// The IngestManager owns map pipelines and hands sessions shared references (released when a
// session finishes); idle ones are evicted. Stopping stops the back end first, so its last
// corrections still reach the consumers.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "common/latency_stats.h"
#include "common/map_types.h"
#include "common/status.h"
#include "core/objects/object_catalog.h"
#include "core/pipeline/ingest_options.h"
#include "core/pipeline/map_consumers.h"
#include "core/slam/bow_vocabulary.h"
#include "core/slam/slam_backend.h"
#include "storage/map_store_opener.h"
#include "storage/storage_writer.h"

namespace semmap {

// What a session's end reports from its map.
struct MapSessionReport {
  uint64_t loop_closures = 0;  // accepted loops whose query keyframe is the session's
  std::optional<SlamBackendStats> backend;
  std::vector<LatencySummary> stages;  // back end, then each consumer's
};

class MapPipeline {
 public:
  MapPipeline(int64_t map_id, std::string map_name);
  ~MapPipeline();  // Stop()
  MapPipeline(const MapPipeline&) = delete;
  MapPipeline& operator=(const MapPipeline&) = delete;

  // Registration, before sessions use the pipeline (the list is fixed afterwards).
  void AddConsumer(std::unique_ptr<MapConsumer> consumer);
  // Starts the back end (once; later calls return it). Its pose events go to the consumers.
  StatusOr<SlamBackend*> EnsureBackend(const SlamBackendOptions& options,
                                       std::shared_ptr<const BowVocabulary> vocabulary,
                                       StorageWriter* writer, SlamRestore restore);
  SlamBackend* backend() const;

  // To every consumer, in registration order; the first error is returned (the keyframe still
  // reaches the others).
  Status PublishKeyframe(const MapKeyframe& keyframe);
  // The session sends no more: the back end drains (its last corrections reach the consumers
  // first), then each consumer ends the session and flushes. Logs one line per consumer.
  Status FinishSession(int64_t session_id, MapSessionReport* report);
  // Every consumer's Flush (a rebuild waits for it).
  Status FlushConsumers();
  // Back end first, then the consumers. Idempotent.
  void Stop();

  int64_t map_id() const { return map_id_; }
  const std::string& map_name() const { return map_name_; }

 private:
  void PublishPoses(std::vector<KeyframePose> poses, bool correction);

  const int64_t map_id_;
  const std::string map_name_;
  std::vector<std::unique_ptr<MapConsumer>> consumers_;  // fixed once sessions use it
  mutable std::mutex backend_mutex_;
  std::unique_ptr<SlamBackend> backend_;
  std::mutex stop_mutex_;
  bool stopped_ = false;
};

// The pipeline the options ask for: objects (when a catalog is given and they are enabled),
// then layers; each restores from the store as `restore` says. No back end yet.
StatusOr<std::unique_ptr<MapPipeline>> MakeMapPipeline(int64_t map_id, const std::string& map_name,
                                                       const IngestOptions& options,
                                                       StorageWriter* writer,
                                                       const ObjectCatalog* objects,
                                                       const StoreRestore& restore);

}  // namespace semmap
