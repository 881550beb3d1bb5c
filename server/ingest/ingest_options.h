#pragma once

#include <cstddef>

#include "common/status.h"
#include "server/slam/keyframe_selector.h"

namespace semmap {

struct IngestOptions {
  // Frames buffered per session between the network and the pipeline; the reader stops
  // reading (HTTP/2 flow control pushes back on the client) while it is full.
  size_t queue_capacity = 8;
  // Largest accepted image payload of one frame (colour + depth bytes).
  size_t max_frame_bytes = 48u << 20;
  KeyframeSelectorOptions keyframes;
  Status Validate() const;
};

}  // namespace semmap
