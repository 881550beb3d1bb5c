#include "core/pipeline/frame_ingestor.h"

#include <chrono>
#include <string>
#include <utility>

#include "common/logging.h"
#include "common/time_util.h"
#include "core/sensor/image_decoding.h"
#include "core/slam/feature_codec.h"

namespace semmap {
namespace {

using Clock = std::chrono::steady_clock;

// The information of a visual estimate, or a weak one (unit, i.e. about one pixel's worth
// per unit of motion) when the mode measures none, so the pose graph stays well posed.
Eigen::Matrix<double, 6, 6> OdometryInformation(const FrameEstimate& estimate) {
  if (estimate.information.allFinite() && estimate.information.diagonal().minCoeff() > 0) {
    return estimate.information;
  }
  return Eigen::Matrix<double, 6, 6>::Identity();
}

}  // namespace

FrameIngestor::FrameIngestor(SessionInfo session, std::unique_ptr<FrameProcessor> processor,
                             std::shared_ptr<MapPipeline> map, bool visual)
    : session_(std::move(session)), processor_(std::move(processor)), map_(std::move(map)) {
  if (map_ && visual) backend_ = map_->backend();
  if (backend_ != nullptr) {
    backend_->RegisterSession(
        session_.id, session_.camera,
        [this](const Eigen::Isometry3d& T) {
          MutexLock lock(correction_mutex_);
          pending_correction_ = pending_correction_ ? T * *pending_correction_ : T;
          for (PendingMapUpdate& u : pending_map_updates_) u.T_new_update = T * u.T_new_update;
        },
        [this](std::shared_ptr<const LocalMapUpdate> update) {
          MutexLock lock(correction_mutex_);
          // A newer update covers the same neighbourhood, refined later: it replaces any
          // still pending.
          pending_map_updates_.clear();
          pending_map_updates_.push_back({std::move(update), Eigen::Isometry3d::Identity()});
        });
  }
}

FrameIngestor::~FrameIngestor() {
  if (!map_) return;
  // Finish normally ran at the session's end; this covers a session that never reached it.
  MapSessionReport report;
  const Status finished = Finish(&report);
  if (!finished.ok()) {
    LogWarning("session '{}': finishing its map pipeline failed: {}", session_.name,
               finished.ToString());
  }
}

StatusOr<FrameIngestor::Ingested> FrameIngestor::Ingest(const DecodedFrame& frame,
                                                        const IngestFrame& wire) {
  ApplyPendingCorrection();
  Ingested out;
  const Clock::time_point t0 = Clock::now();
  SEMMAP_ASSIGN_OR_RETURN(out.estimate, processor_->Process(frame));
  out.tracking_ms = MillisecondsSince(t0);
  const FrameEstimate& estimate = out.estimate;
  if (estimate.new_segment) last_keyframe_seq_.reset();  // no odometry link across the break
  out.previous_keyframe_seq = last_keyframe_seq_;
  out.T_world_previous_keyframe = last_keyframe_pose_;

  TrajectoryPose pose;
  pose.seq = static_cast<int64_t>(frame.seq);
  pose.stamp_ns = frame.stamp_ns;
  pose.T_world_camera = estimate.T_world_camera;
  pose.is_keyframe = estimate.is_keyframe;
  pose.lost = estimate.lost;
  out.batch.frames.emplace_back(session_.id, pose);
  if (!estimate.is_keyframe) return out;

  const Clock::time_point t1 = Clock::now();
  KeyframeRecord kf;
  kf.session_id = session_.id;
  kf.seq = pose.seq;
  kf.stamp_ns = frame.stamp_ns;
  kf.T_world_camera = estimate.T_world_camera;
  SEMMAP_ASSIGN_OR_RETURN(kf.colour, EncodeColourForStorage(*wire.colour, frame.colour));
  if (frame.depth) {
    SEMMAP_ASSIGN_OR_RETURN(kf.depth, EncodeDepthForStorage(*wire.depth, *frame.depth));
    kf.depth_scale = frame.depth->depth_scale;
  } else if (estimate.predicted_depth) {
    // MONO: the network's depth, so restarts and rebuilds see what the live map did.
    SEMMAP_ASSIGN_OR_RETURN(kf.depth,
                            EncodeDepthForStorage(DepthMessage{}, *estimate.predicted_depth));
    kf.depth_scale = estimate.predicted_depth->depth_scale;
  }
  if (estimate.keyframe_features) {
    kf.features_format = std::string(kFeatureCodecFormat);
    kf.features = EncodeFeatures(*estimate.keyframe_features);
  }
  out.batch.keyframes.push_back(std::move(kf));
  if (last_keyframe_seq_) {
    // Odometry edge from the previous keyframe; ids are resolved by the store.
    LinkRecord link;
    link.map_id = session_.map_id;
    link.kind = LinkKind::kOdometry;
    link.from_session_id = session_.id;
    link.from_seq = static_cast<int64_t>(*last_keyframe_seq_);
    link.to_session_id = session_.id;
    link.to_seq = pose.seq;
    link.T_from_to = last_keyframe_pose_.inverse() * estimate.T_world_camera;
    link.information = OdometryInformation(estimate);
    out.batch.links.push_back(link);
  }
  last_keyframe_seq_ = frame.seq;
  last_keyframe_pose_ = estimate.T_world_camera;
  out.keyframe_ms = MillisecondsSince(t1);
  return out;
}

Status FrameIngestor::Publish(const DecodedFrame& frame, const Ingested& ingested) {
  if (backend_ != nullptr) SEMMAP_RETURN_IF_ERROR(FeedBackend(frame, ingested));
  if (map_ && ingested.estimate.is_keyframe) {
    SEMMAP_RETURN_IF_ERROR(PublishKeyframe(frame, ingested.estimate));
  }
  return OkStatus();
}

Status FrameIngestor::FeedBackend(const DecodedFrame& frame, const Ingested& ingested) {
  const FrameEstimate& estimate = ingested.estimate;
  const int64_t seq = static_cast<int64_t>(frame.seq);
  if (estimate.is_keyframe && estimate.keyframe_features) {
    KeyframeEvent event;
    event.session_id = session_.id;
    event.seq = seq;
    event.T_world_keyframe = estimate.T_world_camera;
    event.features = estimate.keyframe_features;
    event.point_ids = estimate.keyframe_point_ids;
    if (ingested.previous_keyframe_seq) {
      event.previous_seq = static_cast<int64_t>(*ingested.previous_keyframe_seq);
      event.T_previous_keyframe =
          ingested.T_world_previous_keyframe.inverse() * estimate.T_world_camera;
    }
    event.information = OdometryInformation(estimate);
    SEMMAP_RETURN_IF_ERROR(backend_->AddKeyframe(std::move(event)));
  }
  if (!last_keyframe_seq_) return OkStatus();  // nothing to anchor to yet
  FrameAnchorEvent anchor;
  anchor.session_id = session_.id;
  anchor.seq = seq;
  anchor.anchor_seq = static_cast<int64_t>(*last_keyframe_seq_);
  anchor.T_anchor_frame = last_keyframe_pose_.inverse() * estimate.T_world_camera;
  anchor.T_world_frame = estimate.T_world_camera;
  return backend_->AddFrame(anchor);
}

Status FrameIngestor::PublishKeyframe(const DecodedFrame& frame, const FrameEstimate& estimate) {
  MapKeyframe keyframe;
  keyframe.session_id = session_.id;
  keyframe.seq = static_cast<int64_t>(frame.seq);
  keyframe.stamp_ns = frame.stamp_ns;
  keyframe.camera = session_.camera;
  keyframe.colour = frame.colour;
  keyframe.depth = frame.depth ? frame.depth : estimate.predicted_depth;
  keyframe.features = estimate.keyframe_features;
  // Visual sessions' keyframes are placed by the back end (in its corrected frame); the others'
  // poses are final as they are.
  if (backend_ == nullptr) keyframe.T_world_keyframe = estimate.T_world_camera;
  return map_->PublishKeyframe(keyframe);
}

void FrameIngestor::ApplyPendingCorrection() {
  std::optional<Eigen::Isometry3d> correction;
  std::vector<PendingMapUpdate> map_updates;
  {
    MutexLock lock(correction_mutex_);
    correction.swap(pending_correction_);
    map_updates.swap(pending_map_updates_);
  }
  if (correction) {
    processor_->ApplyCorrection(*correction);
    last_keyframe_pose_ = *correction * last_keyframe_pose_;
  }
  for (const PendingMapUpdate& u : map_updates)
    processor_->ApplyMapUpdate(*u.update, u.T_new_update);
}

Status FrameIngestor::Finish(MapSessionReport* report) {
  if (!map_) return OkStatus();
  Status finished = map_->FinishSession(session_.id, report);
  // The map is the manager's again: idle once no session holds it.
  backend_ = nullptr;
  map_.reset();
  return finished;
}

}  // namespace semmap
