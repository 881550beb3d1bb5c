#include "core/pipeline/ingest_protocol.h"

#include <string>

#include "common/name_validation.h"

namespace semmap {

StatusOr<KeyframePolicyOptions> ValidateStart(const IngestStartRequest& start,
                                              const KeyframePolicyOptions& defaults) {
  SEMMAP_RETURN_IF_ERROR(ValidateName("map", start.map));
  if (!start.session.empty()) SEMMAP_RETURN_IF_ERROR(ValidateName("session", start.session));
  if (!start.mode) return InvalidArgumentError("start.mode is unspecified");
  SEMMAP_RETURN_IF_ERROR(ValidateCalibration(start.camera).WithContext("start.camera"));
  KeyframePolicyOptions keyframes = defaults;
  if (start.keyframe_min_motion != 0) keyframes.min_motion = start.keyframe_min_motion;
  if (start.keyframe_rotation_weight != 0) {
    keyframes.rotation_weight = start.keyframe_rotation_weight;
  }
  SEMMAP_RETURN_IF_ERROR(keyframes.Validate().WithContext("start.keyframes"));
  return keyframes;
}

Status FrameProtocol::Check(const IngestFrame& frame) const {
  const std::string where = "frame seq " + std::to_string(frame.seq);
  if (frame.seq > kMaxFrameSeq) {
    return InvalidArgumentError(where + " is above the largest allowed seq, 2^63 - 1");
  }
  if (last_seq_ && frame.seq <= *last_seq_) {
    return InvalidArgumentError(where + " is not greater than the previous seq " +
                                std::to_string(*last_seq_));
  }
  if (frame.payload_bytes > max_frame_bytes_) {
    return ResourceExhaustedError(where + " carries " + std::to_string(frame.payload_bytes) +
                                  " image bytes; the limit is " + std::to_string(max_frame_bytes_));
  }
  if (!frame.stamp_ns) return InvalidArgumentError(where + " has no timestamp");
  if (!frame.colour) return InvalidArgumentError(where + " has no colour image");
  return OkStatus();
}

Status FrameProtocol::CheckPosePrior(const IngestFrame& frame) {
  if (!frame.pose_prior) return OkStatus();
  return ValidatePoseTq(*frame.pose_prior)
      .WithContext("frame seq " + std::to_string(frame.seq) + " pose_prior");
}

}  // namespace semmap
