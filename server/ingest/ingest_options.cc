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
  return keyframes.Validate().WithContext("keyframe options");
}

}  // namespace semmap
