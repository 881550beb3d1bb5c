// Trajectory files: TUM (`t tx ty tz qx qy qz qw`) and KITTI odometry (12 numbers per line,
// a row-major 3x4 camera-to-world matrix). Stamps are int64 nanoseconds so a TUM file's
// microsecond stamps survive a read/write round trip exactly.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"

namespace semmap {

struct StampedPose {
  int64_t stamp_ns = 0;
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
};

// Reads a TUM trajectory in file order. Fields may be separated by blanks or commas; '#'
// starts a comment; blank lines are skipped. A malformed line or a quaternion that fails
// ValidatePoseTq is INVALID_ARGUMENT naming "file:line". A file with no poses gives {}.
StatusOr<std::vector<StampedPose>> ReadTumTrajectory(const std::string& path);
// ReadTumTrajectory on a file's content; errors name `path` (a file name or any label).
StatusOr<std::vector<StampedPose>> ParseTumTrajectory(std::string_view content,
                                                      const std::string& path);

// Writes a TUM trajectory with a header comment, stamps as FormatStampSeconds (microseconds)
// and 9 decimals for translation and quaternion (qw >= 0). Non-finite poses are rejected.
Status WriteTumTrajectory(const std::string& path, const std::vector<StampedPose>& poses);
// The content WriteTumTrajectory writes (poses must be finite).
std::string FormatTumTrajectory(const std::vector<StampedPose>& poses);

// Reads KITTI odometry poses. Without `stamps_ns` the stamp of pose i is i (the frame index,
// not a time); with it, stamps_ns[i], and the counts must match. Rotations that are not
// orthonormal (beyond 1e-3) are rejected; the rest are re-orthonormalised.
StatusOr<std::vector<StampedPose>> ReadKittiPoses(const std::string& path,
                                                  const std::vector<int64_t>& stamps_ns = {});
// ReadKittiPoses on a file's content; errors name `path`.
StatusOr<std::vector<StampedPose>> ParseKittiPoses(std::string_view content,
                                                   const std::string& path,
                                                   const std::vector<int64_t>& stamps_ns = {});

// Writes KITTI odometry poses (stamps are not part of the format).
Status WriteKittiPoses(const std::string& path, const std::vector<StampedPose>& poses);
// The content WriteKittiPoses writes (9 significant digits; poses must be finite).
std::string FormatKittiPoses(const std::vector<StampedPose>& poses);

}  // namespace semmap
