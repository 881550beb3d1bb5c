#include "core/pipeline/rgbd_processor.h"

#include <string>

namespace semmap {

StatusOr<std::unique_ptr<RgbdProcessor>> RgbdProcessor::Create(
    RgbdTrackerOptions options, const KeyframePolicyOptions& keyframes,
    const CameraCalibration& camera) {
  options.camera = camera;
  SEMMAP_RETURN_IF_ERROR(keyframes.Validate());
  SEMMAP_ASSIGN_OR_RETURN(
      RgbdTracker tracker,
      RgbdTracker::Create(options, std::make_unique<KeyframePolicy>(keyframes)));
  return std::unique_ptr<RgbdProcessor>(new RgbdProcessor(std::move(tracker)));
}

StatusOr<FrameEstimate> RgbdProcessor::Process(const DecodedFrame& frame) {
  // A frame without depth (sensor dropout, unassociated stamp) is tracked from 2D alone.
  static const DecodedDepth kNoDepth;
  StatusOr<TrackingResult> tracked =
      tracker_.Track(frame.colour, frame.depth ? *frame.depth : kNoDepth, frame.stamp_ns);
  if (!tracked.ok()) {
    return tracked.status().WithContext("frame seq " + std::to_string(frame.seq));
  }
  FrameEstimate estimate;
  estimate.T_world_camera = tracked->T_world_camera;
  estimate.is_keyframe = tracked->is_keyframe;
  estimate.lost = tracked->state == TrackingState::kLost;
  estimate.new_segment = tracked->new_segment;
  estimate.information = tracked->information;
  estimate.keyframe_features = std::move(tracked->keyframe_features);
  estimate.keyframe_point_ids = std::move(tracked->keyframe_point_ids);
  estimate.tracking_timings = tracked->timings;
  return estimate;
}

void RgbdProcessor::ApplyMapUpdate(const LocalMapUpdate& update,
                                   const Eigen::Isometry3d& T_new_update) {
  tracker_.ApplyMapUpdate(update, T_new_update);
}

void RgbdProcessor::ApplyCorrection(const Eigen::Isometry3d& T_corrected_world) {
  tracker_.ApplyCorrection(T_corrected_world);
}

}  // namespace semmap
