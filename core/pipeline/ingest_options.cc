#include "core/pipeline/ingest_options.h"

#include <cmath>
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
  if (max_streams < 1 || max_streams > 10000) {
    return InvalidArgumentError("max concurrent ingest streams must be in 1..10000 (got " +
                                std::to_string(max_streams) + ")");
  }
  if (max_open_maps < 1 || max_open_maps > 10000) {
    return InvalidArgumentError("max open maps must be in 1..10000 (got " +
                                std::to_string(max_open_maps) + ")");
  }
  if (max_idle_maps > max_open_maps) {
    return InvalidArgumentError("max idle maps (" + std::to_string(max_idle_maps) +
                                ") must not exceed max open maps (" +
                                std::to_string(max_open_maps) + ")");
  }
  if (!std::isfinite(idle_timeout_s) || idle_timeout_s < 0 || idle_timeout_s > 86400) {
    return InvalidArgumentError("stream idle timeout must be in [0, 86400] s (0: none)");
  }
  if (!std::isfinite(max_frames_per_second) || max_frames_per_second < 0 ||
      max_frames_per_second > 10000) {
    return InvalidArgumentError(
        "max frames per second per session must be in [0, 10000] (0: none)");
  }
  SEMMAP_RETURN_IF_ERROR(keyframes.Validate().WithContext("keyframe options"));
  // The revisit rule's two halves: the policy skips keyframes where the back end says the map
  // has the view, and only a back end that follows revisits says so; following revisits
  // without the rule replaced a session's own local map with keyframes it did not make
  // (measured: redkitchen ATE +2.6 mm).
  if (keyframes.skip_mapped_views != slam.follow_revisits) {
    return InvalidArgumentError(
        "keyframes.skip_mapped_views and slam.follow_revisits are the two halves of the revisit "
        "keyframe rule: set both on or both off");
  }
  SEMMAP_RETURN_IF_ERROR(layers.Validate());
  SEMMAP_RETURN_IF_ERROR(objects.Validate());
  // The camera is the session's: validate the rest against a plausible one.
  RgbdTrackerOptions probe = tracker;
  probe.camera = CameraCalibration{640, 480, 525, 525, 319.5, 239.5};
  SEMMAP_RETURN_IF_ERROR(probe.Validate().WithContext("tracker options"));
  return slam.Validate().WithContext("slam options");
}

}  // namespace semmap
