// Views of the default room (seed 1) from its circle trajectory, rendered with the default
// synthetic camera: what the mapping tests and benchmarks turn into keyframe clouds.
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "common/camera.h"
#include "common/status.h"
#include "tests/testing/synth/renderer.h"

namespace semmap::synth {

struct RoomView {
  RenderedFrame frame;
  Eigen::Isometry3d T_world_camera;
};

struct RoomCircle {
  CameraCalibration camera;
  std::vector<RoomView> views;
};

// Every `every`-th of `frames` poses of the circle (frames >= 1, every >= 1).
StatusOr<RoomCircle> RenderRoomCircle(int frames, int every);

}  // namespace semmap::synth
