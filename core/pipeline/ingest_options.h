#pragma once

#include <cstddef>

#include "common/status.h"
#include "common/thread_launcher.h"
#include "core/mapping/map_layer_builder.h"
#include "core/objects/object_mapper.h"
#include "core/odometry/rgbd_tracker.h"
#include "core/pipeline/frame_processor.h"
#include "core/slam/keyframe_policy.h"
#include "core/slam/slam_backend.h"
#include "storage/map_store_opener.h"

namespace semmap {

struct IngestOptions {
  // Frames buffered per session between the network and the pipeline; the reader stops
  // reading (HTTP/2 flow control pushes back on the client) while it is full.
  size_t queue_capacity = 8;
  // Largest accepted image payload of one frame (colour + depth bytes).
  size_t max_frame_bytes = 48u << 20;
  // Concurrent ingest streams; one more is refused with RESOURCE_EXHAUSTED (each holds two
  // threads and up to queue_capacity frames).
  size_t max_streams = 64;
  // Maps with a live pipeline (each runs up to three threads and holds its keyframes' clouds);
  // a session on one more map is refused with RESOURCE_EXHAUSTED while all are streaming.
  size_t max_open_maps = 16;
  // Maps whose pipeline is kept after their last session ended, most recently used first (the
  // next session on them starts warm); the others are released and restored on demand.
  size_t max_idle_maps = 1;
  // A stream that sends nothing for this long ends with DEADLINE_EXCEEDED, keeping what it
  // sent (0: never).
  double idle_timeout_s = 60;
  // Frames per second one session may send on average (bursts of two seconds' worth allowed);
  // a faster stream ends with RESOURCE_EXHAUSTED, keeping what came before (0: no limit).
  double max_frames_per_second = 0;
  // How sessions start their threads (empty: LaunchThread); tests make it fail.
  ThreadLauncher launch_thread;
  // Opens a read connection for a map stage's restore (on the stage's thread); empty: restores
  // read through the storage writer, which waits meanwhile.
  MapStoreOpener open_reader;
  KeyframePolicyOptions keyframes;
  // RGBD sessions' front end (its camera and keyframe options come from the session); MONO
  // hybrid sessions' too.
  RgbdTrackerOptions tracker;
  // MONO sessions: the learned VO network (null: MONO is refused with FAILED_PRECONDITION,
  // saying `mono_unavailable`) and how its sessions are tracked.
  std::shared_ptr<const MonoVoModel> mono_model;
  std::string mono_unavailable = "semmapd was started without a VO model (--vo-model)";
  MonoVoMethod mono_method = MonoVoMethod::kHybrid;
  // The per-map back end of RGBD sessions (loop closure, pose graph).
  SlamBackendOptions slam;
  // The per-map 3D layers (occupancy, coloured cloud) built from keyframes with depth.
  MapLayerOptions layers;
  // Object recognition in RGBD sessions' keyframes and the map's object instances.
  ObjectMapperOptions objects;
  Status Validate() const;
};

}  // namespace semmap
