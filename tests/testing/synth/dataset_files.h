// The small text files of a synthetic dataset: camera.yaml (the shared datasets' format, read
// back by client/datasets ReadCameraYaml) and objects.txt, the ground truth of the named
// objects: one `label cx cy cz sx sy sz` line each (world frame, metres; centre and extents of
// the object's axis-aligned bounding box), '#' comments.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/status.h"
#include "tests/testing/synth/scene.h"

namespace semmap::synth {

std::string FormatCameraYaml(const CameraCalibration& camera, double depth_scale);
std::string FormatObjectsFile(const std::vector<NamedObject>& objects);

struct ObjectRecord {
  std::string label;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
};

// Parses objects.txt. INVALID_ARGUMENT naming "file:line" for a malformed line, a negative
// size or a repeated label; NOT_FOUND when the file does not exist.
StatusOr<std::vector<ObjectRecord>> ReadObjectsFile(const std::string& path);

// Writes `content` to `path` (replacing it); UNAVAILABLE naming the file on failure.
Status WriteTextFile(const std::string& path, const std::string& content);

}  // namespace semmap::synth
