// Reader for the datasets' camera.yaml: one flat `key: value   # comment` per line, e.g.
//   width: 640
//   fx: 535.4
//   depth_scale: 5000            # raw depth units per metre (0 = no depth)
//   distortion: [0, 0, 0, 0, 0]  # k1 k2 p1 p2 k3 (OpenCV order)
// Deliberately not a YAML parser: the format is this subset, and strictness (unknown or
// repeated keys are errors) catches typos that a permissive reader would silently ignore.
#pragma once

#include <string>
#include <string_view>

#include "common/camera.h"
#include "common/status.h"

namespace semmap {

struct CameraYaml {
  CameraCalibration camera;
  double depth_scale = 0;  // raw depth units per metre; 0 = the camera has no depth
  double fps = 0;          // frame rate of a plain image folder's frames; 0 = not given
};

// Required keys: width height fx fy cx cy. Optional: depth_scale (default 0, must be >= 0),
// distortion (4 or 5 values, default zeros), fps (frames per second of an image folder, > 0).
// Errors name the file and line; the result passes ValidateCalibration. NOT_FOUND when the file
// does not exist.
StatusOr<CameraYaml> ReadCameraYaml(const std::string& path);
// ReadCameraYaml on a file's content; errors name `path` (a file name or any label).
StatusOr<CameraYaml> ParseCameraYaml(std::string_view content, const std::string& path);

}  // namespace semmap
