// KITTI odometry layout: image_0/NNNNNN.png (left grey camera, rectified), calib.txt (P0..P3
// projection matrices), times.txt (seconds per frame) and optionally poses.txt.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "client/datasets/dataset.h"
#include "common/camera.h"

namespace semmap {

// Intrinsics of camera 0 from calib.txt's "P0:" row (fx=P[0], cx=P[2], fy=P[5], cy=P[6]);
// width and height are left 0 (calib.txt does not know the image size).
StatusOr<CameraCalibration> ReadKittiCalibP0(const std::string& path);
// ReadKittiCalibP0 on calib.txt's content; errors name `path` (a file name or any label).
StatusOr<CameraCalibration> ParseKittiCalibP0(std::string_view content, const std::string& path);

// times.txt's content: one stamp in seconds per line (often "1.038752e-01"), '#' comments and
// blank lines skipped; stamps must increase strictly. Errors name `path` and the line.
StatusOr<std::vector<int64_t>> ParseKittiTimes(std::string_view content, const std::string& path);

// Grey colour, no depth; the image size comes from the first PNG's header.
StatusOr<Dataset> OpenKittiDataset(const std::string& dir);

}  // namespace semmap
