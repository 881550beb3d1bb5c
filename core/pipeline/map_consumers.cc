#include "core/pipeline/map_consumers.h"

#include <fmt/format.h>

#include <utility>

namespace semmap {

LayersConsumer::LayersConsumer(std::unique_ptr<MapLayerBuilder> builder)
    : builder_(std::move(builder)) {}

LayersConsumer::~LayersConsumer() { Stop(); }

Status LayersConsumer::OnKeyframe(const MapKeyframe& keyframe) {
  if (!keyframe.depth) return OkStatus();  // the layers are built from depth
  SEMMAP_RETURN_IF_ERROR(builder_->AddKeyframeImages(
      keyframe.session_id, keyframe.seq, *keyframe.depth, keyframe.colour, keyframe.camera));
  if (!keyframe.T_world_keyframe) return OkStatus();  // placed by the back end
  return builder_->SetKeyframePoses(
      {{keyframe.session_id, keyframe.seq, *keyframe.T_world_keyframe}},
      /*correction=*/false);
}

Status LayersConsumer::OnKeyframePoses(std::vector<KeyframePose> poses, bool correction) {
  return builder_->SetKeyframePoses(std::move(poses), correction);
}

std::string LayersConsumer::Summary() const {
  const MapLayerStats stats = builder_->stats();
  return fmt::format(
      "{} keyframes ({} restored), {} rebuilds, octree {:.1f} MiB for {:.1f} m3 known ({:.0f} "
      "kB/m3), cloud {} points ({:.1f} MiB of leaf sums, {} keyframe moves), keyframe clouds "
      "{:.1f} MiB in memory ({} evicted, {} read back), blobs {:.1f} + {:.1f} MiB",
      stats.keyframes_inserted, stats.restored_keyframes, stats.rebuilds,
      static_cast<double>(stats.octree_bytes) / (1 << 20), stats.known_volume_m3,
      stats.known_volume_m3 > 0
          ? static_cast<double>(stats.octree_bytes) / 1000.0 / stats.known_volume_m3
          : 0.0,
      stats.cloud_points, static_cast<double>(stats.cloud_layer_bytes) / (1 << 20),
      stats.cloud_moves, static_cast<double>(stats.keyframe_cloud_bytes) / (1 << 20),
      stats.keyframes_evicted, stats.keyframe_cloud_reads,
      static_cast<double>(stats.occupancy_blob_bytes) / (1 << 20),
      static_cast<double>(stats.cloud_blob_bytes) / (1 << 20));
}

std::vector<LatencySummary> LayersConsumer::Latencies() const {
  const MapLayerStats stats = builder_->stats();
  return {stats.insert_ms, stats.rebuild_ms, stats.persist_ms};
}

ObjectsConsumer::ObjectsConsumer(std::unique_ptr<ObjectMapper> mapper)
    : mapper_(std::move(mapper)) {}

ObjectsConsumer::~ObjectsConsumer() { Stop(); }

Status ObjectsConsumer::OnKeyframe(const MapKeyframe& keyframe) {
  if (keyframe.features) {  // visual sessions: the tracker's features, the back end's poses
    return mapper_->AddKeyframe(keyframe.session_id, keyframe.seq, keyframe.stamp_ns,
                                keyframe.features, keyframe.camera);
  }
  if (!keyframe.depth) return OkStatus();  // positions need depth
  SEMMAP_RETURN_IF_ERROR(mapper_->AddKeyframeImages(keyframe.session_id, keyframe.seq,
                                                    keyframe.stamp_ns, keyframe.colour,
                                                    *keyframe.depth, keyframe.camera));
  if (!keyframe.T_world_keyframe) return OkStatus();
  return mapper_->SetKeyframePoses(
      {{keyframe.session_id, keyframe.seq, *keyframe.T_world_keyframe}},
      /*correction=*/false);
}

Status ObjectsConsumer::OnKeyframePoses(std::vector<KeyframePose> poses, bool correction) {
  return mapper_->SetKeyframePoses(std::move(poses), correction);
}

std::string ObjectsConsumer::Summary() const {
  const ObjectMapperStats stats = mapper_->stats();
  return fmt::format(
      "{} keyframes searched for {} types, {} detections, {} rejected by xi, {} observations, {} "
      "instances",
      stats.keyframes_searched, stats.models, stats.detections, stats.rejected_by_xi,
      stats.observations, stats.instances);
}

std::vector<LatencySummary> ObjectsConsumer::Latencies() const {
  return {mapper_->stats().recognise_ms};
}

}  // namespace semmap
