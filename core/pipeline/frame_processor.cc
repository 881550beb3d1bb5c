#include "core/pipeline/frame_processor.h"

#include <string>

#include "core/pipeline/mono_processor.h"
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
                                                             const FrameProcessorContext& context,
                                                             const CameraCalibration& camera) {
  switch (mode) {
    case SessionMode::kKnownPoses:
      return std::unique_ptr<FrameProcessor>(std::make_unique<KnownPosesProcessor>(kf));
    case SessionMode::kRgbd: {
      SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<RgbdProcessor> processor,
                              RgbdProcessor::Create(context.tracker, kf, camera));
      return std::unique_ptr<FrameProcessor>(std::move(processor));
    }
    case SessionMode::kMono: {
      if (context.mono_model == nullptr) {
        return FailedPreconditionError("MONO sessions are not available: " +
                                       context.mono_unavailable);
      }
      SEMMAP_ASSIGN_OR_RETURN(std::unique_ptr<MonoProcessor> processor,
                              MonoProcessor::Create(context.mono_model, context.mono_method, kf,
                                                    context.tracker, camera));
      return std::unique_ptr<FrameProcessor>(std::move(processor));
    }
  }
  return InvalidArgumentError("unknown session mode");
}

}  // namespace semmap
