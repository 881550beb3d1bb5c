#include "server/ingest/frame_processor.h"

#include <string>

#include "server/ingest/rgbd_processor.h"

namespace semmap {

StatusOr<FrameEstimate> KnownPosesProcessor::Process(const DecodedFrame& frame) {
  if (!frame.T_world_camera_prior) {
    return InvalidArgumentError("frame seq " + std::to_string(frame.seq) +
                                " has no pose_prior; KNOWN_POSES sessions need T_world_camera "
                                "on every frame");
  }
  FrameEstimate estimate;
  estimate.T_world_camera = *frame.T_world_camera_prior;
  estimate.is_keyframe = selector_.Decide(estimate.T_world_camera);
  return estimate;
}

StatusOr<std::unique_ptr<FrameProcessor>> MakeFrameProcessor(SessionMode mode,
                                                             const KeyframeSelectorOptions& kf,
                                                             const RgbdTrackerOptions& tracker,
                                                             const CameraCalibration& camera) {
  switch (mode) {
    case SessionMode::kKnownPoses:
      return std::unique_ptr<FrameProcessor>(std::make_unique<KnownPosesProcessor>(kf));
    case SessionMode::kRgbd: {
      RgbdTrackerOptions options = tracker;
      options.keyframes = kf;
      SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<RgbdProcessor> processor,
                              RgbdProcessor::Create(options, camera));
      return std::unique_ptr<FrameProcessor>(std::move(processor));
    }
    case SessionMode::kMono:
      return UnimplementedError("MONO sessions (learned visual odometry) are not implemented yet");
  }
  return InvalidArgumentError("unknown session mode");
}

}  // namespace semmap
