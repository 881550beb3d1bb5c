#include "core/pipeline/frame_processor.h"

#include <string>

#include "core/pipeline/rgbd_processor.h"

namespace semmap {

StatusOr<FrameEstimate> KnownPosesProcessor::Process(const DecodedFrame& frame) {
  if (!frame.T_world_camera_prior) {
    return InvalidArgumentError("frame seq " + std::to_string(frame.seq) +
                                " has no pose_prior; KNOWN_POSES sessions need T_world_camera "
                                "on every frame");
  }
  FrameEstimate estimate;
  estimate.T_world_camera = *frame.T_world_camera_prior;
  KeyframeCandidate candidate;
  candidate.evidence = KeyframeEvidence::kKnownPose;
  candidate.T_world_camera = estimate.T_world_camera;
  estimate.is_keyframe = keyframes_.Decide(candidate);
  return estimate;
}

StatusOr<std::unique_ptr<FrameProcessor>> MakeFrameProcessor(SessionMode mode,
                                                             const KeyframePolicyOptions& kf,
                                                             const RgbdTrackerOptions& tracker,
                                                             const CameraCalibration& camera) {
  switch (mode) {
    case SessionMode::kKnownPoses:
      return std::unique_ptr<FrameProcessor>(std::make_unique<KnownPosesProcessor>(kf));
    case SessionMode::kRgbd: {
      SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<RgbdProcessor> processor,
                              RgbdProcessor::Create(tracker, kf, camera));
      return std::unique_ptr<FrameProcessor>(std::move(processor));
    }
    case SessionMode::kMono:
      return UnimplementedError("MONO sessions (learned visual odometry) are not implemented yet");
  }
  return InvalidArgumentError("unknown session mode");
}

}  // namespace semmap
