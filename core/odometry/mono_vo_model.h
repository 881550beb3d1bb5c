// The learned monocular VO network (training/, issue 13) as the server runs it: an ONNX graph of
// one recurrent step and its JSON sidecar (input size, canonical camera, normalisation, I/O
// names and shapes, sha256 of the graph). Loaded once at start; every MONO session gets its own
// runner (cv::dnn::Net is not safe to share between threads) with its own recurrent state.
//
// One step: `image` (the current canonical frame) plus the recurrent state the sidecar lists
// (for the shipped network the previous frame's encoder features prev_f1..prev_f3 and the LSTM's
// h, c) -> pose6 (T_prev_cur: translation metres, axis-angle radians), depth (metres, canonical
// camera) and the state's next values (f1..f3, h_out, c_out).
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "common/status.h"
#include "core/odometry/canonical_camera.h"

namespace semmap {

// One recurrent input: fed with the previous step's `output` (zeros for a sequence's first frame).
struct MonoVoState {
  std::string input;
  std::string output;
  std::vector<int> shape;  // batch 1, 2 to 4 dimensions
  // The first frame's value is thrown away and zeros carried instead (the LSTM's h and c: the
  // first frame has no motion to learn from).
  bool discard_first = false;
};

struct MonoVoModelInfo {
  CanonicalCamera camera;        // the network's input size and intrinsics
  std::array<double, 3> mean{};  // x = (rgb / 255 - mean) / std, R, G, B
  std::array<double, 3> stddev{};
  std::vector<MonoVoState> state;  // what each step feeds back to the next
  std::string sha256;              // of the ONNX file (hex)
};

// Parses the sidecar JSON (format "semmap_vo/1"). INVALID_ARGUMENT naming the field.
StatusOr<MonoVoModelInfo> ParseMonoVoSidecar(std::string_view json);

// T_prev_cur from the network's pose6 (tx, ty, tz, rx, ry, rz); INVALID_ARGUMENT when a value
// is not finite or the motion is beyond any camera's (10 m or pi radians in one step).
StatusOr<Eigen::Isometry3d> PoseFromPose6(const std::array<float, 6>& pose6);

class MonoVoRunner;

class MonoVoModel {
 public:
  // Reads `onnx_path` and the sidecar next to it (same name, .json), checks the sha256, builds
  // the network once and runs one step to check the outputs' shapes. NOT_FOUND for a missing
  // file, DATA_LOSS for a graph whose sha256 differs from the sidecar's or that OpenCV cannot
  // import, INVALID_ARGUMENT for a bad sidecar.
  static StatusOr<std::shared_ptr<const MonoVoModel>> Load(const std::string& onnx_path);

  // A runner with a fresh state. RESOURCE_EXHAUSTED / DATA_LOSS when the network cannot be built.
  StatusOr<std::unique_ptr<MonoVoRunner>> NewRunner() const;

  const MonoVoModelInfo& info() const { return info_; }
  const std::string& path() const { return path_; }

 private:
  MonoVoModel(std::string path, std::string onnx, MonoVoModelInfo info);

  std::string path_;
  std::string onnx_;  // the graph's bytes: each runner builds its network from them
  MonoVoModelInfo info_;
};

}  // namespace semmap
