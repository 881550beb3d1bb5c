// Messages of one ingest stream and the results it reports, as plain structs (no protobuf):
// the service converts the wire messages into these and the pipeline answers through IngestSink.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "common/camera.h"
#include "common/latency_stats.h"
#include "common/map_types.h"
#include "common/pose.h"
#include "common/status.h"
#include "core/sensor/image_message.h"

namespace semmap {

struct IngestStartRequest {
  std::string map;
  std::string session;              // empty: generated
  std::optional<SessionMode> mode;  // nullopt: the client left it unspecified
  CameraCalibration camera;
  double keyframe_min_motion = 0;  // 0: server default
  double keyframe_rotation_weight = 0;
};

struct IngestFrame {
  uint64_t seq = 0;
  std::optional<int64_t> stamp_ns;
  std::optional<ImageMessage> colour;
  std::optional<DepthMessage> depth;
  std::optional<PoseTq> pose_prior;  // T_world_camera
  size_t payload_bytes = 0;          // image bytes, for size limits
};

struct IngestEnd {};

// A message the service could not even convert (e.g. a malformed calibration): the pipeline
// finishes the stream with this status when it reaches it, after storing what came before.
struct IngestInvalid {
  Status status;
};

using IngestMessage = std::variant<IngestStartRequest, IngestFrame, IngestEnd, IngestInvalid>;

struct FrameAckInfo {
  uint64_t seq = 0;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  bool is_keyframe = false;
  bool lost = false;
  std::optional<uint64_t> durable_seq;
};

struct IngestProgressInfo {
  uint64_t frames_received = 0;
  uint64_t frames_processed = 0;
  uint64_t keyframes = 0;
  std::optional<uint64_t> durable_seq;
  uint32_t queue_depth = 0;
};

struct IngestSummaryInfo {
  std::string map;
  std::string session;
  uint64_t frames = 0;
  uint64_t keyframes = 0;
  uint64_t lost_frames = 0;    // visual tracking failed (pose held at the last good one)
  uint64_t loop_closures = 0;  // loops the back end accepted with this session's keyframes
  uint64_t new_segments = 0;   // tracking restarted after a sustained loss
  std::optional<uint64_t> durable_seq;
  double duration_s = 0;
  // Per-stage latency inside the server: decode, tracking, keyframe, storage_commit, frame.
  std::vector<LatencySummary> stages;
};

// How a session reports back. Calls come from the session's worker thread and the storage
// writer thread; implementations must be thread-safe and must never block.
class IngestSink {
 public:
  virtual ~IngestSink() = default;
  virtual void OnStarted(const SessionInfo& session) = 0;
  virtual void OnAck(const FrameAckInfo& ack) = 0;
  virtual void OnProgress(const IngestProgressInfo& progress) = 0;
  // The session's input queue has room again: a paused reader may read the next message.
  virtual void OnQueueRoom() = 0;
  // Exactly once, after everything else; the status is the stream's final status.
  virtual void OnFinished(const Status& status, const IngestSummaryInfo& summary) = 0;
};

}  // namespace semmap
