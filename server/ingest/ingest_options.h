#pragma once

#include <cstddef>

#include "common/status.h"
#include "server/odometry/rgbd_tracker.h"
#include "server/slam/keyframe_selector.h"
#include "server/slam/slam_backend.h"

namespace semmap {

struct IngestOptions {
  // Frames buffered per session between the network and the pipeline; the reader stops
  // reading (HTTP/2 flow control pushes back on the client) while it is full.
  size_t queue_capacity = 8;
  // Largest accepted image payload of one frame (colour + depth bytes).
  size_t max_frame_bytes = 48u << 20;
  KeyframeSelectorOptions keyframes;
  // RGBD sessions' front end (its camera and keyframe options come from the session).
  RgbdTrackerOptions tracker;
  // The per-map back end of RGBD sessions (loop closure, pose graph).
  SlamBackendOptions slam;
  Status Validate() const;
};

}  // namespace semmap
