// Pinhole camera calibration with OpenCV-order distortion, shared by server and client.
#pragma once

#include <array>
#include <cstdint>

#include "common/status.h"

namespace semmap {

struct CameraCalibration {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 5> distortion{};  // k1 k2 p1 p2 k3

  bool HasDistortion() const;
};

// Largest camera a session may declare (8K video is 33 MP; a 48 MP phone sensor fits).
inline constexpr int64_t kMaxCameraPixels = 50'000'000;

// Rejects NaN/inf, non-positive size or focal length, and principal points far outside the image.
Status ValidateCalibration(const CameraCalibration& camera);

}  // namespace semmap
