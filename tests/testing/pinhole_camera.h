// A distortion-free pinhole camera for tests and benchmarks, in one line instead of six.
#pragma once

#include "common/camera.h"

namespace semmap::testing {

// width x height pixels, focal length `focal` (pixels) on both axes, the principal point at
// (cx, cy).
inline CameraCalibration PinholeCamera(int width, int height, double focal, double cx, double cy) {
  CameraCalibration camera;
  camera.width = width;
  camera.height = height;
  camera.fx = camera.fy = focal;
  camera.cx = cx;
  camera.cy = cy;
  return camera;
}

// The same with the principal point at the image's centre, ((width - 1) / 2, (height - 1) / 2).
inline CameraCalibration PinholeCamera(int width, int height, double focal) {
  return PinholeCamera(width, height, focal, (width - 1) / 2.0, (height - 1) / 2.0);
}

}  // namespace semmap::testing
