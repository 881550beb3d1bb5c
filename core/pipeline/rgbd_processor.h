// RGBD sessions: every frame is tracked by the visual front end (RgbdTracker); keyframes carry
// their features on to the SLAM back end, which may move the map and send corrections back.
#pragma once

#include <memory>

#include "core/odometry/rgbd_tracker.h"
#include "core/pipeline/frame_processor.h"
#include "core/slam/keyframe_policy.h"

namespace semmap {

class RgbdProcessor final : public FrameProcessor {
 public:
  // `options.camera` is replaced by the session's calibration; keyframes are decided by a
  // KeyframePolicy of `keyframes`. INVALID_ARGUMENT for bad options.
  static StatusOr<std::unique_ptr<RgbdProcessor>> Create(RgbdTrackerOptions options,
                                                         const KeyframePolicyOptions& keyframes,
                                                         const CameraCalibration& camera);
  // Frames without depth are tracked but never keyframes; a frame the tracker cannot place
  // keeps the last pose (state lost) rather than failing the stream.
  StatusOr<FrameEstimate> Process(const DecodedFrame& frame) override;
  void ApplyCorrection(const Eigen::Isometry3d& T_corrected_world) override;
  void ApplyMapUpdate(const LocalMapUpdate& update, const Eigen::Isometry3d& T_new_update) override;

 private:
  explicit RgbdProcessor(RgbdTracker tracker) : tracker_(std::move(tracker)) {}
  RgbdTracker tracker_;
};

}  // namespace semmap
