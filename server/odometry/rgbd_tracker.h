// RGB-D tracking front end: every frame is tracked against the current reference keyframe
// (guided matching around the constant-velocity prediction first, full matching as the
// fallback), PnP + motion-only refinement give its pose, and a frame becomes the new reference
// when it moved far enough (KeyframeSelector) or when the tracked inliers fall below a fraction
// of what the reference had. When tracking fails, the last few keyframes are tried
// (relocalisation) before the frame is reported lost.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <optional>
#include <string_view>
#include <vector>

#include "common/camera.h"
#include "common/status.h"
#include "server/odometry/feature_extractor.h"
#include "server/odometry/feature_matcher.h"
#include "server/odometry/motion_estimator.h"
#include "server/sensor/image_decoding.h"
#include "server/slam/keyframe_selector.h"

namespace semmap {

struct RgbdTrackerOptions {
  CameraCalibration camera;
  FeatureExtractorOptions features;
  FeatureMatcherOptions matcher;
  MotionEstimatorOptions motion;
  KeyframeSelectorOptions keyframes;
  // New keyframe when the inliers against the reference fall below this fraction of the
  // inliers of the first frame tracked against it.
  double min_inlier_fraction = 0.4;
  // Guided matching is trusted when it finds at least this many inliers; else full matching.
  int min_guided_inliers = 80;
  // Keyframes kept (features and poses) for relocalisation, the reference included.
  int relocalisation_keyframes = 5;
  // Pose of the first frame.
  Eigen::Isometry3d T_world_first = Eigen::Isometry3d::Identity();

  Status Validate() const;
};

enum class TrackingState { kTracking, kRelocalised, kLost };
std::string_view TrackingStateName(TrackingState state);

struct TrackingTimings {
  double extract_ms = 0;
  double match_ms = 0;
  double pose_ms = 0;
  double total_ms = 0;
};

struct TrackingResult {
  // Always finite. While lost: the last tracked pose.
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  bool is_keyframe = false;  // this frame became the new reference
  int num_matches = 0;       // matches used for the accepted (or last tried) estimate
  int num_inliers = 0;
  TrackingState state = TrackingState::kTracking;
  bool used_guided_matching = false;
  TrackingTimings timings;
};

class RgbdTracker {
 public:
  // INVALID_ARGUMENT for invalid options or calibration.
  static StatusOr<RgbdTracker> Create(const RgbdTrackerOptions& options);

  // `image`: 8-bit grey or BGR of the camera's size; `depth`: registered depth of that size.
  // INVALID_ARGUMENT for bad input (the tracker's state is unchanged); losing track is not an
  // error but state kLost. Stamps must increase.
  StatusOr<TrackingResult> Track(const cv::Mat& image, const DecodedDepth& depth, int64_t stamp_ns);

  int num_keyframes() const { return num_keyframes_; }
  const RgbdTrackerOptions& options() const { return options_; }

 private:
  struct Keyframe {
    FrameFeatures features;
    std::vector<int> depth_index;  // keypoints with a 3D point
    cv::Mat depth_descriptors;     // their descriptor rows, in depth_index order
    Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
    int tracked_inliers = -1;  // inliers of the first frame tracked against it
  };
  struct Attempt {
    std::optional<MotionEstimate> estimate;  // nullopt: too little support
    int num_matches = 0;
    double match_ms = 0;
    double pose_ms = 0;
  };

  RgbdTracker(RgbdTrackerOptions options, FeatureExtractor extractor)
      : options_(std::move(options)),
        extractor_(std::move(extractor)),
        selector_(options_.keyframes) {}

  // Full matching of `keyframe` against `current` and PnP.
  StatusOr<Attempt> TrackFull(const Keyframe& keyframe, const FrameFeatures& current,
                              const std::optional<Eigen::Isometry3d>& T_ref_cur_guess) const;
  StatusOr<Attempt> TrackGuided(const Keyframe& keyframe, const FrameFeatures& current,
                                const Eigen::Isometry3d& T_ref_cur_predicted) const;
  StatusOr<Attempt> Estimate(const Keyframe& keyframe, const FrameFeatures& current,
                             const std::vector<cv::DMatch>& matches,
                             const std::optional<Eigen::Isometry3d>& guess) const;
  void MakeKeyframe(FrameFeatures features, const Eigen::Isometry3d& T_world_camera);

  RgbdTrackerOptions options_;
  FeatureExtractor extractor_;
  KeyframeSelector selector_;
  std::deque<Keyframe> keyframes_;  // back() is the reference
  int num_keyframes_ = 0;
  std::optional<Eigen::Isometry3d> T_world_last_;
  Eigen::Isometry3d T_last_velocity_ = Eigen::Isometry3d::Identity();  // T_prev_last
  std::optional<int64_t> last_stamp_ns_;
};

}  // namespace semmap
