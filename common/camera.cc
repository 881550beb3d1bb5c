#include "common/camera.h"

#include <cmath>
#include <string>

namespace semmap {

bool CameraCalibration::HasDistortion() const {
  for (double d : distortion) {
    if (d != 0.0) return true;
  }
  return false;
}

Status ValidateCalibration(const CameraCalibration& c) {
  if (c.width <= 0 || c.height <= 0 || c.width > 16384 || c.height > 16384) {
    return InvalidArgumentError("camera size " + std::to_string(c.width) + "x" +
                                std::to_string(c.height) + " is not in 1..16384");
  }
  // Every frame of the session is decoded at this size: the cap bounds what one frame costs.
  if (static_cast<int64_t>(c.width) * c.height > kMaxCameraPixels) {
    return InvalidArgumentError("camera size " + std::to_string(c.width) + "x" +
                                std::to_string(c.height) + " has more than " +
                                std::to_string(kMaxCameraPixels / 1000000) + " megapixels");
  }
  for (double v : {c.fx, c.fy, c.cx, c.cy}) {
    if (!std::isfinite(v)) return InvalidArgumentError("camera intrinsics have a non-finite value");
  }
  for (double d : c.distortion) {
    if (!std::isfinite(d)) return InvalidArgumentError("camera distortion has a non-finite value");
  }
  if (c.fx <= 0 || c.fy <= 0) {
    return InvalidArgumentError("camera focal lengths must be positive (fx=" +
                                std::to_string(c.fx) + ", fy=" + std::to_string(c.fy) + ")");
  }
  // A principal point more than one image size away from the image is a calibration error.
  if (c.cx < -c.width || c.cx > 2.0 * c.width || c.cy < -c.height || c.cy > 2.0 * c.height) {
    return InvalidArgumentError("camera principal point (" + std::to_string(c.cx) + ", " +
                                std::to_string(c.cy) + ") is far outside the image");
  }
  return OkStatus();
}

}  // namespace semmap
