// A dataset on disk as the client streams it: camera, frames in time order with their image
// paths, and optional ground truth. Images are not read here (see image_file.h).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "client/datasets/trajectory_io.h"
#include "common/camera.h"
#include "common/status.h"

namespace semmap {

struct DatasetFrame {
  int64_t seq = 0;  // 0..N-1 in time order
  int64_t stamp_ns = 0;
  std::string colour_path;                // dataset dir joined with the listed path
  std::optional<std::string> depth_path;  // set only when a depth image was associated
};

struct Dataset {
  std::string kind;  // "tum", "kitti" or "images"
  std::string dir;
  CameraCalibration camera;
  double depth_scale = 0;  // raw depth units per metre; 0 when the dataset has no depth
  bool colour_is_grey = false;
  std::vector<DatasetFrame> frames;
  std::vector<StampedPose> ground_truth;  // camera-to-world, sorted by stamp; empty when none
};

// Opens a dataset directory, recognising its layout: TUM RGB-D (rgb.txt), KITTI odometry
// (image_0/ and times.txt), or a plain image folder with a camera.yaml (image_folder_dataset.h).
// Every listed image is checked to exist (NOT_FOUND naming it), so a broken dataset fails here
// rather than halfway through a stream.
StatusOr<Dataset> OpenDataset(const std::string& dir);

}  // namespace semmap
