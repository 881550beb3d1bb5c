// One MONO session's learned VO: the network's recurrent state (the previous frame's features,
// the LSTM's h and c: whatever the sidecar's state list names) carried from frame to frame, reset
// at a session's start and after a tracking loss. Each step gives the motion since the previous
// frame and the frame's depth.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>
#include <opencv2/dnn.hpp>
#include <optional>
#include <vector>

#include "common/status.h"
#include "core/odometry/mono_vo_model.h"

namespace semmap {

struct MonoVoStep {
  // T_prev_cur, metric; nullopt for the first frame after a reset.
  std::optional<Eigen::Isometry3d> T_prev_cur;
  cv::Mat depth;  // CV_32F metres in the canonical camera
};

class MonoVoRunner {
 public:
  MonoVoRunner(const cv::dnn::Net& net, MonoVoModelInfo info);
  MonoVoRunner(const MonoVoRunner&) = delete;
  MonoVoRunner& operator=(const MonoVoRunner&) = delete;

  // `canonical_bgr`: the frame resampled to the network's camera (CanonicalResampler), BGR8.
  // INTERNAL when OpenCV fails, INVALID_ARGUMENT for a wrong image or an implausible output.
  StatusOr<MonoVoStep> Step(const cv::Mat& canonical_bgr);
  // The next frame starts a new sequence (as the first of a session).
  void Reset();
  bool has_state() const { return !state_.empty(); }

 private:
  cv::Mat Blob(const cv::Mat& canonical_bgr) const;

  cv::dnn::Net net_;
  MonoVoModelInfo info_;
  std::vector<cv::String> output_names_;  // pose6, depth, then the state's outputs
  std::vector<cv::Mat> state_;            // one per info_.state entry; empty after Reset
};

}  // namespace semmap
