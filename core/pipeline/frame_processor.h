// Turns a decoded frame into a pose and a keyframe decision; one implementation per session mode.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <string>
#include <vector>

#include "common/map_types.h"
#include "common/status.h"
#include "core/odometry/mono_vo_model.h"
#include "core/odometry/rgbd_tracker.h"
#include "core/sensor/frame_features.h"
#include "core/sensor/image_decoding.h"
#include "core/slam/keyframe_policy.h"

namespace semmap {

struct DecodedFrame {
  uint64_t seq = 0;
  int64_t stamp_ns = 0;
  cv::Mat colour;  // BGR8 or mono8
  std::optional<DecodedDepth> depth;
  std::optional<Eigen::Isometry3d> T_world_camera_prior;
};

struct FrameEstimate {
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  bool is_keyframe = false;
  bool lost = false;  // visual tracking failed: the pose is the last good one
  // Tracking restarted after a sustained loss: this keyframe has no odometry to the previous
  // ones (a new graph component until place recognition reconnects it).
  bool new_segment = false;
  // Visual modes: information of the pose w.r.t. the keyframe it was tracked from, and the
  // new keyframe's features (for loop closure and storage) when is_keyframe.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
  std::shared_ptr<const FrameFeatures> keyframe_features;
  // RGBD keyframes: the tracker's map-point id of each keypoint, -1 for none (may be empty).
  std::vector<int64_t> keyframe_point_ids;
  // MONO: the network's depth of the frame in the camera's pixels, stored with keyframes and
  // given to the map's consumers as a sensor's would be.
  std::optional<DecodedDepth> predicted_depth;
  // RGBD: where tracking's time went (feature extraction, matching, pose estimation).
  std::optional<TrackingTimings> tracking_timings;
};

class FrameProcessor {
 public:
  virtual ~FrameProcessor() = default;
  virtual StatusOr<FrameEstimate> Process(const DecodedFrame& frame) = 0;
  // The back end moved the map: continue in the corrected frame (visual modes).
  virtual void ApplyCorrection(const Eigen::Isometry3d& /*T_corrected_world*/) {}
  // The back end's points around the session's tracker (RGBD), as RgbdTracker::ApplyMapUpdate.
  virtual void ApplyMapUpdate(const LocalMapUpdate& /*update*/,
                              const Eigen::Isometry3d& /*T_new_update*/) {}
};

// KNOWN_POSES: the client's pose is the truth; only the keyframe decision is ours.
class KnownPosesProcessor final : public FrameProcessor {
 public:
  explicit KnownPosesProcessor(KeyframePolicyOptions options) : keyframes_(options) {}
  StatusOr<FrameEstimate> Process(const DecodedFrame& frame) override;

 private:
  KeyframePolicy keyframes_;
};

// How MONO sessions are tracked: the learned VO network's motion alone (net), or feature
// tracking against the network's depth, so that the network sets the scale (hybrid).
enum class MonoVoMethod { kNet, kHybrid };

// What MakeFrameProcessor needs beyond the session's start message.
struct FrameProcessorContext {
  // RGBD sessions' front end (its camera is replaced by the session's); MONO hybrid too.
  RgbdTrackerOptions tracker;
  // The VO network MONO sessions run (null: MONO is refused with FAILED_PRECONDITION saying
  // why, `mono_unavailable`).
  std::shared_ptr<const MonoVoModel> mono_model;
  std::string mono_unavailable = "semmapd was started without a VO model (--vo-model)";
  MonoVoMethod mono_method = MonoVoMethod::kHybrid;
};

// Every mode decides keyframes with a KeyframePolicy of `kf`.
StatusOr<std::unique_ptr<FrameProcessor>> MakeFrameProcessor(SessionMode mode,
                                                             const KeyframePolicyOptions& kf,
                                                             const FrameProcessorContext& context,
                                                             const CameraCalibration& camera);

}  // namespace semmap
