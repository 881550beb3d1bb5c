#include "server/ingest/ingest_options.h"

#include <string>

namespace semmap {

Status IngestOptions::Validate() const {
  if (queue_capacity < 1 || queue_capacity > 1024) {
    return InvalidArgumentError("ingest queue capacity must be in 1..1024 (got " +
                                std::to_string(queue_capacity) + ")");
  }
  if (max_frame_bytes < 1024) {
    return InvalidArgumentError("max frame bytes must be at least 1024");
  }
  SEMMAP_RETURN_IF_ERROR(keyframes.Validate().WithContext("keyframe options"));
  SEMMAP_RETURN_IF_ERROR(layers.Validate());
  SEMMAP_RETURN_IF_ERROR(objects.Validate());
  // The camera is the session's: validate the rest against a plausible one.
  RgbdTrackerOptions probe = tracker;
  probe.camera = CameraCalibration{640, 480, 525, 525, 319.5, 239.5};
  probe.keyframes = keyframes;
  SEMMAP_RETURN_IF_ERROR(probe.Validate().WithContext("tracker options"));
  return slam.Validate().WithContext("slam options");
}

}  // namespace semmap
