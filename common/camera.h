// Pinhole camera calibration with OpenCV-order distortion, shared by server and client.
#pragma once

#include <array>

#include "common/status.h"

namespace semmap {

struct CameraCalibration {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 5> distortion{};  // k1 k2 p1 p2 k3

  bool HasDistortion() const;
};

// Rejects NaN/inf, non-positive size or focal length, and principal points far outside the image.
Status ValidateCalibration(const CameraCalibration& camera);

}  // namespace semmap
