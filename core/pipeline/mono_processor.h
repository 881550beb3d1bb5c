// MONO sessions: one colour camera, poses from the learned VO network (training/, issue 13).
// Every frame is resampled to the network's canonical camera and stepped through it with the
// session's recurrent state; its predicted depth is mapped back to the camera's pixels and goes
// wherever a sensor's depth would (keyframes, map layers, objects, loop closure features).
//  - net: the network's frame-to-frame motion, chained; keyframes by the motion norm;
//  - hybrid: the RGB-D feature tracker (local map, PnP) run on the predicted depth, so features
//    give the accuracy and the network the metric scale; where the tracker loses the frame,
//    the network's motion carries the pose on.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <optional>

#include "core/odometry/canonical_camera.h"
#include "core/odometry/feature_extractor.h"
#include "core/odometry/mono_vo.h"
#include "core/odometry/rgbd_tracker.h"
#include "core/pipeline/frame_processor.h"
#include "core/slam/keyframe_policy.h"

namespace semmap {

// Depth units per metre of the predicted depth stored with MONO keyframes (as TUM's 16-bit PNG).
inline constexpr double kPredictedDepthScale = 5000.0;

class MonoProcessor final : public FrameProcessor {
 public:
  // INVALID_ARGUMENT for a camera the network cannot take (too far from its focal length, or
  // more than 4 MP: resample the frames on the client); DATA_LOSS / RESOURCE_EXHAUSTED when the
  // network cannot be built.
  static StatusOr<std::unique_ptr<MonoProcessor>> Create(std::shared_ptr<const MonoVoModel> model,
                                                         MonoVoMethod method,
                                                         const KeyframePolicyOptions& keyframes,
                                                         RgbdTrackerOptions tracker,
                                                         const CameraCalibration& camera);

  StatusOr<FrameEstimate> Process(const DecodedFrame& frame) override;
  void ApplyCorrection(const Eigen::Isometry3d& T_corrected_world) override;

 private:
  MonoProcessor(std::shared_ptr<const MonoVoModel> model, MonoVoMethod method,
                CanonicalResampler resampler, std::unique_ptr<MonoVoRunner> runner,
                KeyframePolicy keyframes, FeatureExtractor extractor,
                std::optional<RgbdTracker> tracker);

  StatusOr<FrameEstimate> ProcessNet(const DecodedFrame& frame, const MonoVoStep& step,
                                     const DecodedDepth& depth);
  StatusOr<FrameEstimate> ProcessHybrid(const DecodedFrame& frame, const MonoVoStep& step,
                                        const DecodedDepth& depth);

  std::shared_ptr<const MonoVoModel> model_;
  MonoVoMethod method_;
  CanonicalResampler resampler_;
  std::unique_ptr<MonoVoRunner> runner_;
  KeyframePolicy keyframes_;            // net: the motion-norm rule
  FeatureExtractor extractor_;          // net: keyframe features with the predicted depth
  std::optional<RgbdTracker> tracker_;  // hybrid
  // The last pose reported (net: the chained motion; hybrid: where the network carries on).
  std::optional<Eigen::Isometry3d> T_world_last_;
};

// The session's cameras MONO takes: at most this many pixels (the canonical resampling keeps
// per-pixel maps).
inline constexpr int64_t kMaxMonoCameraPixels = 4'000'000;

}  // namespace semmap
