// Turns a session's validated, decoded frames into what the map keeps: the frame processor's
// pose and keyframe decision, the write batch (the frame's pose; a keyframe's images, features
// and odometry link from the previous keyframe), and, once that batch is on its way to the
// store, the events for the map's pipeline (back end: keyframes and frame anchors; consumers:
// keyframes). Back-end corrections arrive on the back end's thread and are applied before the
// next frame. Everything else runs on the session's worker thread.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <optional>

#include "common/map_types.h"
#include "common/thread_annotations.h"
#include "core/pipeline/frame_processor.h"
#include "core/pipeline/ingest_types.h"
#include "core/pipeline/map_pipeline.h"
#include "storage/map_store.h"

namespace semmap {

class FrameIngestor {
 public:
  // `map` may be null (no pipeline: frames are only stored). A visual session's map has its
  // back end running; the ingestor registers for its corrections until Finish.
  FrameIngestor(SessionInfo session, std::unique_ptr<FrameProcessor> processor,
                std::shared_ptr<MapPipeline> map, bool visual);
  ~FrameIngestor();
  FrameIngestor(const FrameIngestor&) = delete;
  FrameIngestor& operator=(const FrameIngestor&) = delete;

  struct Ingested {
    FrameEstimate estimate;
    WriteBatch batch;
    double tracking_ms = 0;
    double keyframe_ms = 0;  // building the keyframe's record (encoding), when it is one
    // The session's keyframe before this frame, for the back end's odometry measurement.
    std::optional<uint64_t> previous_keyframe_seq;
    Eigen::Isometry3d T_world_previous_keyframe = Eigen::Isometry3d::Identity();
  };
  // Applies a pending correction, tracks the frame and builds its batch.
  StatusOr<Ingested> Ingest(const DecodedFrame& frame, const IngestFrame& wire);
  // After the batch was submitted: the back end gets the frame (and its keyframe), the map's
  // consumers the keyframe.
  Status Publish(const DecodedFrame& frame, const Ingested& ingested);
  // The map's pipeline finishes the session (its writes land, its report is filled) and is
  // released. Idempotent.
  Status Finish(MapSessionReport* report);

  const SessionInfo& session() const { return session_; }

 private:
  Status FeedBackend(const DecodedFrame& frame, const Ingested& ingested);
  Status PublishKeyframe(const DecodedFrame& frame, const FrameEstimate& estimate);
  void ApplyPendingCorrection() SEMMAP_EXCLUDES(correction_mutex_);

  const SessionInfo session_;
  std::unique_ptr<FrameProcessor> processor_;
  std::shared_ptr<MapPipeline> map_;  // released by Finish
  SlamBackend* backend_ = nullptr;    // map_'s, for visual sessions
  std::optional<uint64_t> last_keyframe_seq_;
  Eigen::Isometry3d last_keyframe_pose_ = Eigen::Isometry3d::Identity();
  // Corrections from the back end's thread, applied before the next frame is tracked.
  Mutex correction_mutex_;
  std::optional<Eigen::Isometry3d> pending_correction_ SEMMAP_GUARDED_BY(correction_mutex_);
  // Map point updates in arrival order, each with the corrections that arrived after it
  // (T_new_update), so it is applied in the frame the tracker will be in.
  struct PendingMapUpdate {
    std::shared_ptr<const LocalMapUpdate> update;
    Eigen::Isometry3d T_new_update = Eigen::Isometry3d::Identity();
  };
  std::vector<PendingMapUpdate> pending_map_updates_ SEMMAP_GUARDED_BY(correction_mutex_);
};

}  // namespace semmap
