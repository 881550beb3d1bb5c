// What consumes a map's keyframes and keyframe poses, behind one interface: the map pipeline
// (map_pipeline.h) publishes each keyframe once its own write was submitted, and the poses the
// SLAM back end gives keyframes (or a session's final ones); a consumer is one registration
// there. The two consumers today: the 3D layers and the objects.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/latency_stats.h"
#include "common/map_types.h"
#include "common/status.h"
#include "core/mapping/map_layer_builder.h"
#include "core/objects/object_mapper.h"
#include "core/sensor/frame_features.h"
#include "core/sensor/image_decoding.h"

namespace semmap {

// A keyframe as the map's consumers see it (the Mats and features are shared, not copied).
struct MapKeyframe {
  int64_t session_id = 0, seq = 0, stamp_ns = 0;
  CameraCalibration camera;
  cv::Mat colour;                                 // BGR8 or mono8
  std::optional<DecodedDepth> depth;              // registered to colour
  std::shared_ptr<const FrameFeatures> features;  // visual sessions: the tracker's
  // Set when the pose is final as it is (sessions without a SLAM back end); visual sessions'
  // keyframes are placed by the back end's pose events instead.
  std::optional<Eigen::Isometry3d> T_world_keyframe;
};

class MapConsumer {
 public:
  virtual ~MapConsumer() = default;
  virtual const std::string& name() const = 0;
  virtual const char* kind() const = 0;  // "layers", "objects": in the operator's log line
  // May block while the consumer's queue is full; UNAVAILABLE once it stopped.
  virtual Status OnKeyframe(const MapKeyframe& keyframe) = 0;
  // A new keyframe's pose (correction false) or every moved keyframe's after an optimisation.
  virtual Status OnKeyframePoses(std::vector<KeyframePose> poses, bool correction) = 0;
  // The session sends no more keyframes.
  virtual Status OnSessionEnd(int64_t /*session_id*/) { return OkStatus(); }
  // Everything handed over so far is done and committed; the first error since the last Flush.
  virtual Status Flush() = 0;
  virtual void Stop() = 0;
  // For the operator's log line and the session summary.
  virtual std::string Summary() const = 0;
  virtual std::vector<LatencySummary> Latencies() const = 0;
};

// The occupancy and cloud layers: keyframes with depth.
class LayersConsumer final : public MapConsumer {
 public:
  explicit LayersConsumer(std::unique_ptr<MapLayerBuilder> builder);
  ~LayersConsumer() override;  // Stop()
  const std::string& name() const override { return builder_->name(); }
  const char* kind() const override { return "layers"; }
  Status OnKeyframe(const MapKeyframe& keyframe) override;
  Status OnKeyframePoses(std::vector<KeyframePose> poses, bool correction) override;
  Status Flush() override { return builder_->Flush(); }
  void Stop() override { builder_->Stop(); }
  std::string Summary() const override;
  std::vector<LatencySummary> Latencies() const override;

 private:
  std::unique_ptr<MapLayerBuilder> builder_;
};

// Object recognition and instances: keyframes with features, or with images and depth.
class ObjectsConsumer final : public MapConsumer {
 public:
  explicit ObjectsConsumer(std::unique_ptr<ObjectMapper> mapper);
  ~ObjectsConsumer() override;  // Stop()
  const std::string& name() const override { return mapper_->name(); }
  const char* kind() const override { return "objects"; }
  Status OnKeyframe(const MapKeyframe& keyframe) override;
  Status OnKeyframePoses(std::vector<KeyframePose> poses, bool correction) override;
  Status OnSessionEnd(int64_t session_id) override { return mapper_->EndSession(session_id); }
  Status Flush() override { return mapper_->Flush(); }
  void Stop() override { mapper_->Stop(); }
  std::string Summary() const override;
  std::vector<LatencySummary> Latencies() const override;

 private:
  std::unique_ptr<ObjectMapper> mapper_;
};

}  // namespace semmap
