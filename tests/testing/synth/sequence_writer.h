// Writes a rendered synthetic sequence in the TUM RGB-D layout of the shared datasets, so
// client/datasets OpenDataset reads it like a real recording:
//   rgb/<stamp>.png      colour, BGR8 PNG
//   depth/<stamp>.png    depth, 16-bit PNG, kDepthScale (5000) units per metre, 0 = none
//   rgb.txt, depth.txt   `timestamp path` lists (colour and depth share stamps)
//   groundtruth.txt      `timestamp tx ty tz qx qy qz qw`, camera-to-world
//   camera.yaml          width height fx fy cx cy depth_scale distortion
//   objects.txt          `label cx cy cz sx sy sz` per named object (see dataset_files.h)
//   objects/<label>.png  one template image per named object (see object_template.h)
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "client/datasets/trajectory_io.h"
#include "common/camera.h"
#include "common/status.h"
#include "tests/testing/synth/noise.h"
#include "tests/testing/synth/scene.h"

namespace semmap::synth {

struct SequenceOptions {
  CameraCalibration camera;  // pinhole, no distortion
  NoiseOptions noise;
  uint64_t noise_seed = 0;
  bool write_object_templates = true;
  // Called after each frame is written with (frames written, total frames); may be empty.
  std::function<void(size_t, size_t)> progress;
};

// The default camera: 640x480, fx = fy = 525, principal point at the image centre (pixel
// centres at integer coordinates), no distortion; other sizes scale fx, fy with the width.
CameraCalibration DefaultSyntheticCamera(int width = 640, int height = 480);

// Renders every pose of `trajectory` (stamps strictly increasing) and writes the sequence into
// `dir`, which is created when missing and must otherwise be empty. The image lists are
// written last, so an interrupted run leaves no openable dataset.
Status WriteTumSequence(const std::string& dir, const Scene& scene,
                        const std::vector<StampedPose>& trajectory, const SequenceOptions& options);

}  // namespace semmap::synth
