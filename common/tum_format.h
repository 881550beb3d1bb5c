// One line of a TUM trajectory file: "stamp tx ty tz qx qy qz qw\n" (T_world_camera, 9 decimals),
// the form every semmap writer (export, CLI, dataset tools) produces.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>

namespace semmap {

std::string FormatTumPoseLine(int64_t stamp_ns, const Eigen::Isometry3d& T_world_camera);

}  // namespace semmap
