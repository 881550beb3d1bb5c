// Object recognition and object instances of one map, on a thread of its own (off the tracking
// path).
//
// Sessions hand over each keyframe's features (with depth); the keyframe is searched for every
// object type visible in the map (ObjectCatalog) once its next keyframe has arrived, so the
// neighbour check (xi = N_c / N_n) sees the keyframes on both sides; a session's last keyframe
// is decided at EndSession with its previous one only. Accepted detections become observations
// in the keyframe's frame, written through the storage writer. The SLAM back end (or a
// KNOWN_POSES session) says where keyframes are; whenever observations or poses change, the
// observations are moved into the map frame with the current poses and fused into instances,
// which replace the map's stored instances (queries read those). So a pose-graph correction
// moves every object with the keyframes that saw it.
//
// A mapper started for a map with stored observations (after a restart) loads them and the
// keyframe poses first.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "common/camera.h"
#include "common/latency_stats.h"
#include "common/map_types.h"
#include "common/object_types.h"
#include "common/pipeline_stage.h"
#include "common/status.h"
#include "core/objects/object_catalog.h"
#include "core/odometry/feature_extractor.h"
#include "core/recognition/object_fusion.h"
#include "core/sensor/image_decoding.h"
#include "storage/map_store_opener.h"
#include "storage/pending_writes.h"
#include "storage/storage_writer.h"

namespace semmap {

struct ObjectMapperOptions {
  bool enabled = true;   // false: keyframes are not searched for objects
  bool apply_xi = true;  // the neighbour check (false: every verified detection is kept)
  ObjectFusionOptions fusion;
  size_t queue_capacity = 64;

  Status Validate() const;
};

struct ObjectMapperStats {
  uint64_t keyframes_searched = 0;
  uint64_t detections = 0;  // verified geometrically
  uint64_t rejected_by_xi = 0;
  uint64_t observations = 0;  // accepted (stored)
  uint64_t restored_observations = 0;
  uint64_t fusions = 0;
  size_t instances = 0;  // after the last fusion
  size_t models = 0;     // object types the last keyframe was searched for
  size_t queue_high_water = 0;
  LatencySummary recognise_ms;  // per keyframe (detection + neighbour check)
  LatencySummary fuse_ms;
};

namespace object_mapper_internal {

struct KeyframeItem {
  std::shared_ptr<const FrameFeatures> features;  // null: extracted from the images
  int64_t session_id = 0, seq = 0, stamp_ns = 0;
  CameraCalibration camera;
  cv::Mat colour;
  DecodedDepth depth;
};
struct SessionEnd {
  int64_t session_id = 0;
};
struct PoseUpdate {
  std::vector<KeyframePose> poses;
};
using Event = std::variant<KeyframeItem, SessionEnd, PoseUpdate>;

}  // namespace object_mapper_internal

// A pipeline stage (common/pipeline_stage.h): Flush, Stop and metrics() come from there.
class ObjectMapper final : public PipelineStage<object_mapper_internal::Event> {
 public:
  // `catalog` and `writer` must outlive the mapper. INVALID_ARGUMENT for bad options;
  // RESOURCE_EXHAUSTED when its thread cannot start. `stage` overrides the stage's
  // configuration (synchronous mode, thread launcher); its name and queue capacity are set here.
  static StatusOr<std::unique_ptr<ObjectMapper>> Start(int64_t map_id, ObjectMapperOptions options,
                                                       const ObjectCatalog* catalog,
                                                       StorageWriter* writer, StoreRestore restore,
                                                       StageConfig stage = {});
  ~ObjectMapper() override;  // Stop()

  // A keyframe of a session, after its own write was submitted (observations name it by
  // (session, seq)). Block only while the queue is full; UNAVAILABLE after Stop().
  Status AddKeyframe(int64_t session_id, int64_t seq, int64_t stamp_ns,
                     std::shared_ptr<const FrameFeatures> features,
                     const CameraCalibration& camera);
  // A keyframe of a session without visual tracking (KNOWN_POSES): its features are extracted
  // here, on the mapper's thread, from the colour and depth images (shared, not copied).
  Status AddKeyframeImages(int64_t session_id, int64_t seq, int64_t stamp_ns, cv::Mat colour,
                           DecodedDepth depth, const CameraCalibration& camera);
  // The session sends no more keyframes: its last one is decided now.
  Status EndSession(int64_t session_id);
  // Keyframe poses, as MapLayerBuilder takes them.
  Status SetKeyframePoses(std::vector<KeyframePose> poses, bool correction);
  // Flush(): waits until everything handed over so far is recognised, fused and committed;
  // returns the first error since the last Flush.

  ObjectMapperStats stats() const;

 private:
  using KeyframeItem = object_mapper_internal::KeyframeItem;
  using SessionEnd = object_mapper_internal::SessionEnd;
  using PoseUpdate = object_mapper_internal::PoseUpdate;
  using Key = std::pair<int64_t, int64_t>;  // (session_id, seq)

  ObjectMapper(int64_t map_id, ObjectMapperOptions options, const ObjectCatalog* catalog,
               StorageWriter* writer, StoreRestore restore, StageConfig stage);
  // The stage's hooks (its thread).
  void OnStart() override;
  void Handle(object_mapper_internal::Event& event) override;
  std::optional<Clock::time_point> OnIdle() override;
  Status OnFlush() override;
  void OnStop() override;

  void Restore();
  void Handle(KeyframeItem& item);
  void Handle(const SessionEnd& end);
  void Handle(const PoseUpdate& update);
  // Searches `target` with its neighbours (either may be null).
  void Recognise(const KeyframeItem& target, const KeyframeItem* before, const KeyframeItem* after);
  void FuseAndWrite();

  const int64_t map_id_;
  const ObjectMapperOptions options_;
  const ObjectCatalog* const catalog_;
  StorageWriter* const writer_;
  const StoreRestore restore_;

  // Mapper-thread state.
  std::map<int64_t, std::deque<KeyframeItem>> recent_;  // per session: the last two keyframes
  std::map<int64_t, FeatureExtractor> extractors_;      // per session, for AddKeyframeImages
  std::map<Key, Eigen::Isometry3d> poses_;
  std::vector<ObjectObservation> observations_;  // every accepted one of the map
  bool dirty_ = false;  // observations or poses changed since the last fusion

  PendingWrites writes_;  // observation and instance writes, and the errors Flush reports
  mutable std::mutex mutex_;
  ObjectMapperStats stats_;
  LatencyStats recognise_ms_{"recognise"};
  LatencyStats fuse_ms_{"fuse_objects"};
};

}  // namespace semmap
