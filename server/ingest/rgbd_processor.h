// RGBD sessions: every frame is tracked by the visual front end (RgbdTracker); keyframes carry
// their features on to the SLAM back end, which may move the map and send corrections back.
#pragma once

#include <memory>

#include "server/ingest/frame_processor.h"
#include "server/odometry/rgbd_tracker.h"

namespace semmap {

class RgbdProcessor final : public FrameProcessor {
 public:
  // `options.camera` is replaced by the session's calibration. INVALID_ARGUMENT for bad options.
  static StatusOr<std::unique_ptr<RgbdProcessor>> Create(RgbdTrackerOptions options,
                                                         const CameraCalibration& camera);
  // Frames without depth are tracked but never keyframes; a frame the tracker cannot place
  // keeps the last pose (state lost) rather than failing the stream.
  StatusOr<FrameEstimate> Process(const DecodedFrame& frame) override;
  void ApplyCorrection(const Eigen::Isometry3d& T_corrected_world) override;

 private:
  explicit RgbdProcessor(RgbdTracker tracker) : tracker_(std::move(tracker)) {}
  RgbdTracker tracker_;
};

}  // namespace semmap
