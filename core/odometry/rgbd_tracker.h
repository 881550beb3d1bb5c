// RGB-D tracking front end: every frame is tracked against the local map (the fused 3D points
// of the last few keyframes, LocalMap) by projection around the constant-velocity prediction,
// PnP-RANSAC and a motion-only refinement on reprojection and inverse-depth errors
// (RefinePoseRgbd). When that finds too little support, the reference keyframe is matched
// directly (guided, then full matching) and the map is tried again from that pose. A frame
// becomes a keyframe (and adds its points to the map) when the KeyframeDecider it was given
// says so (core/slam/keyframe_policy.h: the one keyframe rule). When tracking fails, the last few
// keyframes are tried (relocalisation) before the frame is reported lost. After a sustained loss
// (the camera never comes back to those keyframes) the tracker re-initialises: a frame that still
// cannot be placed starts a new map segment at the last known pose (TrackingResult::new_segment).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include "common/camera.h"
#include "common/status.h"
#include "core/odometry/feature_extractor.h"
#include "core/odometry/feature_matcher.h"
#include "core/odometry/keyframe_decider.h"
#include "core/odometry/local_map.h"
#include "core/odometry/motion_estimator.h"
#include "core/odometry/rgbd_refiner.h"
#include "core/sensor/image_decoding.h"

namespace semmap {

struct RgbdTrackerOptions {
  CameraCalibration camera;
  FeatureExtractorOptions features;
  FeatureMatcherOptions matcher;
  MotionEstimatorOptions motion;
  LocalMapOptions local_map;
  RgbdRefinerOptions refiner;
  // Second projection of the local map at the refined pose, with this search radius (pixels),
  // to collect the matches the prediction missed; 0 disables it.
  double map_refine_radius_px = 4.0;
  // The wide search around the predicted pose looks for the points the last frame found
  // first (when at least min_guided_inliers of them are in view), the whole map only at the
  // second, tight projection (which needs map_refine_radius_px > 0). false: both passes over
  // every point in view (slower; the same poses to within a millimetre on the test sequences).
  bool search_last_frame_points_first = true;
  // Guided matching is trusted when it finds at least this many inliers; else full matching.
  int min_guided_inliers = 80;
  // When the local map at the constant-velocity prediction gives fewer than min_guided_inliers,
  // before the reference keyframe is tried: the map around the last pose (the camera stopped,
  // or a frame repeated), then around the prediction with matcher.guided_radius_px times
  // map_retry_radius_scale (it sped up or turned). On a revisit that makes no keyframes
  // (KeyframePolicyOptions::skip_mapped_views) the reference may be metres behind: the map is
  // the only view at hand.
  bool map_retries = true;
  double map_retry_radius_scale = 2.0;
  // Keyframes kept (features and poses) for relocalisation, the reference included.
  int relocalisation_keyframes = 5;
  // After this many consecutive lost frames with depth (frames without depth neither count nor
  // break the run), the next frame with depth that can still not be tracked or relocalised
  // starts a new map segment (TrackingState::kReinitialised) if it has at least
  // 2 * motion.min_inliers keypoints with depth; else it stays lost and the next one is tried.
  // 0 disables it (lost until the camera sees the kept keyframes again).
  int reinitialise_after_lost = 5;
  // Pose of the first frame.
  Eigen::Isometry3d T_world_first = Eigen::Isometry3d::Identity();

  Status Validate() const;
};

// kReinitialised: lost for too long, this frame started a new map segment (new_segment).
enum class TrackingState { kTracking, kRelocalised, kLost, kReinitialised };
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
  bool used_guided_matching = false;  // the pose came from the local map or guided matching
  // State kReinitialised: this frame is the first keyframe of a new map segment (is_keyframe,
  // keyframe_features set, information zero), placed at the last known pose. It has no
  // odometry to the previous keyframes: the tracker forgot them (local map and relocalisation
  // keyframes start afresh from this frame); only place recognition can reconnect the segments.
  bool new_segment = false;
  TrackingTimings timings;
  // When is_keyframe: the new keyframe's features (3D points in its own camera frame), shared
  // with the back end (loop closure, place recognition), never modified after publication.
  std::shared_ptr<const FrameFeatures> keyframe_features;
  // When is_keyframe: per keypoint of keyframe_features, the id of the local-map point it
  // observes (matched, or started by it), -1 for none. Ids are unique for the tracker's
  // lifetime, so the back end can follow each point across keyframes (map points, BA).
  std::vector<int64_t> keyframe_point_ids;
  // Information (as MotionEstimate::information) of this frame's pose estimate w.r.t. the
  // keyframe it was tracked against; zero when lost or for the first frame.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
};

class RgbdTracker {
 public:
  // `keyframes` decides which tracked frames become keyframes (the tracker tells it about
  // segment starts and corrections too). INVALID_ARGUMENT for invalid options or calibration,
  // or no decider.
  static StatusOr<RgbdTracker> Create(const RgbdTrackerOptions& options,
                                      std::unique_ptr<KeyframeDecider> keyframes);

  // `image`: 8-bit grey or BGR of the camera's size; `depth`: registered depth of that size, or
  // empty (a sensor dropout): the frame is tracked from its 2D features but never becomes a
  // keyframe (and before the first keyframe it is kLost). INVALID_ARGUMENT for bad input (the
  // tracker's state is unchanged); losing track is not an error but state kLost. Stamps must
  // increase.
  StatusOr<TrackingResult> Track(const cv::Mat& image, const DecodedDepth& depth, int64_t stamp_ns);

  // The back end moved the map: every pose the tracker holds (keyframes, local map points,
  // last pose, prediction) is re-expressed as T_corrected_world * T_world_x, so tracking
  // continues in the corrected frame.
  void ApplyCorrection(const Eigen::Isometry3d& T_corrected_world);
  // The back end's refined points around the tracker (LocalMapUpdate), positions re-expressed
  // as T_new_update * p: tracking then matches against them, including points the local map
  // had already forgotten (a revisited place). Its keyframes' poses tell the keyframe decider
  // which views the map already has.
  void ApplyMapUpdate(const LocalMapUpdate& update, const Eigen::Isometry3d& T_new_update);

  int num_keyframes() const { return num_keyframes_; }
  size_t num_map_points() const { return map_.size(); }
  const RgbdTrackerOptions& options() const { return options_; }

 private:
  struct Keyframe {
    std::shared_ptr<const FrameFeatures> features;
    std::vector<int> depth_index;  // keypoints with a 3D point
    cv::Mat depth_descriptors;     // their descriptor rows, in depth_index order
    Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  };
  struct Attempt {
    std::optional<MotionEstimate> estimate;  // nullopt: too little support
    int num_matches = 0;
    double match_ms = 0;
    double pose_ms = 0;
  };
  // An accepted pose of the current frame.
  struct Solution {
    Eigen::Isometry3d T_world_current = Eigen::Isometry3d::Identity();
    Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
    int num_matches = 0;
    int num_inliers = 0;
    std::vector<int> point_of_keypoint;  // map point of each current keypoint (-1); may be empty
    std::vector<int> visible;            // map points predicted in view
    std::vector<int> found;              // map points matched as inliers
  };

  RgbdTracker(RgbdTrackerOptions options, FeatureExtractor extractor,
              std::unique_ptr<KeyframeDecider> keyframes)
      : options_(std::move(options)),
        extractor_(std::move(extractor)),
        keyframes_decider_(std::move(keyframes)),
        map_(options_.local_map, options_.camera) {}

  // Projection matching against the local map around T_world_guess within `radius_px`,
  // PnP-RANSAC and the RGB-D refinement (then a second, tighter projection). nullopt: too little
  // support.
  StatusOr<std::optional<Solution>> TrackLocalMap(const FrameFeatures& current,
                                                  const Eigen::Isometry3d& T_world_guess,
                                                  double radius_px, double* match_ms,
                                                  double* pose_ms) const;
  // One matching pass against the map points `predicted` holds (nullopt: left out), then
  // PnP-RANSAC and the RGB-D refinement. nullopt: too little support.
  struct MapPass {
    std::vector<cv::DMatch> matches;  // queryIdx: map point, trainIdx: current keypoint
    RgbdRefinement refined;
  };
  StatusOr<std::optional<MapPass>> MatchAndEstimate(
      const FrameFeatures& current, const std::vector<std::optional<cv::Point2f>>& predicted,
      const Eigen::Isometry3d& T_world_guess, const FeatureMatcherOptions& matcher,
      double* match_ms, double* pose_ms) const;
  std::vector<RgbdObservation> ObservationsOf(const FrameFeatures& current,
                                              const std::vector<cv::DMatch>& matches) const;
  // Map points predicted in view of T_world_camera (indices) with their predicted pixels.
  void ProjectMap(const Eigen::Isometry3d& T_world_camera,
                  std::vector<std::optional<cv::Point2f>>* predicted,
                  std::vector<int>* visible) const;

  // Full matching of `keyframe` against `current` and PnP.
  StatusOr<Attempt> TrackFull(const Keyframe& keyframe, const FrameFeatures& current,
                              const std::optional<Eigen::Isometry3d>& T_ref_cur_guess) const;
  StatusOr<Attempt> TrackGuided(const Keyframe& keyframe, const FrameFeatures& current,
                                const Eigen::Isometry3d& T_ref_cur_predicted) const;
  StatusOr<Attempt> Estimate(const Keyframe& keyframe, const FrameFeatures& current,
                             const std::vector<cv::DMatch>& matches,
                             const std::optional<Eigen::Isometry3d>& guess) const;
  // Forgets the keyframes, the local map and the motion, and starts afresh from `features` as
  // the first keyframe at T_world_camera.
  std::shared_ptr<const FrameFeatures> StartSegment(FrameFeatures features,
                                                    const Eigen::Isometry3d& T_world_camera);
  std::shared_ptr<const FrameFeatures> MakeKeyframe(FrameFeatures features,
                                                    const Eigen::Isometry3d& T_world_camera,
                                                    const std::vector<int>& point_of_keypoint);

  RgbdTrackerOptions options_;
  FeatureExtractor extractor_;
  std::unique_ptr<KeyframeDecider> keyframes_decider_;
  LocalMap map_;
  std::deque<Keyframe> keyframes_;  // back() is the reference
  // The keyframes of the back end's latest map update (world frame), for the decider.
  std::vector<Eigen::Isometry3d> mapped_keyframes_;
  int num_keyframes_ = 0;
  std::optional<Eigen::Isometry3d> T_world_last_;
  Eigen::Isometry3d T_last_velocity_ = Eigen::Isometry3d::Identity();  // T_prev_last
  std::optional<int64_t> last_stamp_ns_;
  int lost_with_depth_ = 0;                  // consecutive lost frames with depth
  int64_t frame_number_ = 0;                 // frames given to Track, this one included
  std::vector<int64_t> keyframe_point_ids_;  // of the keyframe MakeKeyframe made last
};

}  // namespace semmap
