#include "server/odometry/rgbd_tracker.h"

#include <chrono>
#include <cmath>
#include <string>
#include <utility>

namespace semmap {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace

std::string_view TrackingStateName(TrackingState state) {
  switch (state) {
    case TrackingState::kTracking:
      return "tracking";
    case TrackingState::kRelocalised:
      return "relocalised";
    case TrackingState::kLost:
      return "lost";
  }
  return "unknown";
}

Status RgbdTrackerOptions::Validate() const {
  SEMMAP_RETURN_IF_ERROR(ValidateCalibration(camera).WithContext("tracker camera"));
  SEMMAP_RETURN_IF_ERROR(features.Validate());
  SEMMAP_RETURN_IF_ERROR(matcher.Validate());
  SEMMAP_RETURN_IF_ERROR(motion.Validate());
  SEMMAP_RETURN_IF_ERROR(keyframes.Validate());
  if (!std::isfinite(min_inlier_fraction) || min_inlier_fraction < 0 || min_inlier_fraction >= 1) {
    return InvalidArgumentError("tracker min_inlier_fraction must be in [0, 1)");
  }
  if (min_guided_inliers < motion.min_inliers) {
    return InvalidArgumentError("tracker min_guided_inliers must be >= motion.min_inliers");
  }
  if (relocalisation_keyframes < 1 || relocalisation_keyframes > 100) {
    return InvalidArgumentError("tracker relocalisation_keyframes must be in [1, 100]");
  }
  if (!T_world_first.matrix().allFinite()) {
    return InvalidArgumentError("tracker T_world_first must be finite");
  }
  return OkStatus();
}

StatusOr<RgbdTracker> RgbdTracker::Create(const RgbdTrackerOptions& options) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  SEMMAP_ASSIGN_OR_RETURN(FeatureExtractor extractor,
                          FeatureExtractor::Create(options.features, options.camera));
  return RgbdTracker(options, std::move(extractor));
}

void RgbdTracker::MakeKeyframe(FrameFeatures features, const Eigen::Isometry3d& T_world_camera) {
  Keyframe kf;
  kf.T_world_camera = T_world_camera;
  for (size_t i = 0; i < features.size(); ++i) {
    if (features.has_depth[i]) kf.depth_index.push_back(static_cast<int>(i));
  }
  kf.depth_descriptors.create(static_cast<int>(kf.depth_index.size()), features.descriptors.cols,
                              features.descriptors.type());
  for (size_t r = 0; r < kf.depth_index.size(); ++r) {
    features.descriptors.row(kf.depth_index[r])
        .copyTo(kf.depth_descriptors.row(static_cast<int>(r)));
  }
  kf.features = std::move(features);
  keyframes_.push_back(std::move(kf));
  while (static_cast<int>(keyframes_.size()) > options_.relocalisation_keyframes) {
    keyframes_.pop_front();
  }
  ++num_keyframes_;
}

StatusOr<RgbdTracker::Attempt> RgbdTracker::Estimate(
    const Keyframe& kf, const FrameFeatures& current, const std::vector<cv::DMatch>& matches,
    const std::optional<Eigen::Isometry3d>& guess) const {
  // queryIdx indexes kf.depth_index, trainIdx the current keypoints.
  std::vector<Eigen::Vector3d> points;
  std::vector<cv::Point2f> pixels;
  points.reserve(matches.size());
  pixels.reserve(matches.size());
  for (const cv::DMatch& m : matches) {
    points.push_back(
        kf.features
            .points_camera[static_cast<size_t>(kf.depth_index[static_cast<size_t>(m.queryIdx)])]);
    pixels.push_back(current.keypoints[static_cast<size_t>(m.trainIdx)].pt);
  }
  Attempt attempt;
  attempt.num_matches = static_cast<int>(matches.size());
  const Clock::time_point start = Clock::now();
  StatusOr<MotionEstimate> estimate =
      EstimateMotion(points, pixels, options_.camera, options_.motion, guess);
  attempt.pose_ms = MsSince(start);
  if (estimate.ok()) {
    attempt.estimate = std::move(estimate).value();
  } else if (estimate.status().code() != StatusCode::kFailedPrecondition) {
    return estimate.status();  // a real failure, not just too little support
  }
  return attempt;
}

StatusOr<RgbdTracker::Attempt> RgbdTracker::TrackGuided(
    const Keyframe& kf, const FrameFeatures& current,
    const Eigen::Isometry3d& T_ref_cur_predicted) const {
  const Eigen::Isometry3d T_cur_ref = T_ref_cur_predicted.inverse();
  const CameraCalibration& c = options_.camera;
  std::vector<std::optional<cv::Point2f>> predicted(kf.depth_index.size());
  for (size_t r = 0; r < kf.depth_index.size(); ++r) {
    const Eigen::Vector3d p =
        T_cur_ref * kf.features.points_camera[static_cast<size_t>(kf.depth_index[r])];
    if (!(p.z() > 0.05)) continue;
    const double u = c.fx * p.x() / p.z() + c.cx, v = c.fy * p.y() / p.z() + c.cy;
    if (u < -10 || v < -10 || u > c.width + 10 || v > c.height + 10) continue;
    predicted[r] = cv::Point2f(static_cast<float>(u), static_cast<float>(v));
  }
  const Clock::time_point start = Clock::now();
  SEMMAP_ASSIGN_OR_RETURN(std::vector<cv::DMatch> matches,
                          MatchGuided(kf.depth_descriptors, predicted, current.descriptors,
                                      current.keypoints, options_.matcher));
  const double match_ms = MsSince(start);
  SEMMAP_ASSIGN_OR_RETURN(Attempt attempt, Estimate(kf, current, matches, T_ref_cur_predicted));
  attempt.match_ms = match_ms;
  return attempt;
}

StatusOr<RgbdTracker::Attempt> RgbdTracker::TrackFull(
    const Keyframe& kf, const FrameFeatures& current,
    const std::optional<Eigen::Isometry3d>& guess) const {
  const Clock::time_point start = Clock::now();
  SEMMAP_ASSIGN_OR_RETURN(
      std::vector<cv::DMatch> matches,
      MatchDescriptors(kf.depth_descriptors, current.descriptors, options_.matcher));
  const double match_ms = MsSince(start);
  SEMMAP_ASSIGN_OR_RETURN(Attempt attempt, Estimate(kf, current, matches, guess));
  attempt.match_ms = match_ms;
  return attempt;
}

StatusOr<TrackingResult> RgbdTracker::Track(const cv::Mat& image, const DecodedDepth& depth,
                                            int64_t stamp_ns) {
  const Clock::time_point start = Clock::now();
  const auto Inliers = [](const Attempt* a) {
    return a->estimate ? static_cast<int>(a->estimate->inliers.size()) : -1;
  };
  if (depth.raw.empty()) return InvalidArgumentError("RGB-D tracking needs a depth image");
  if (last_stamp_ns_ && stamp_ns <= *last_stamp_ns_) {
    return InvalidArgumentError("frame stamps must increase (" + std::to_string(stamp_ns) +
                                " after " + std::to_string(*last_stamp_ns_) + ")");
  }
  TrackingResult result;
  SEMMAP_ASSIGN_OR_RETURN(FrameFeatures current,
                          extractor_.Extract(image, depth.raw, depth.depth_scale));
  result.timings.extract_ms = MsSince(start);
  last_stamp_ns_ = stamp_ns;

  if (keyframes_.empty()) {
    selector_ = KeyframeSelector(options_.keyframes);
    selector_.Decide(options_.T_world_first);
    MakeKeyframe(std::move(current), options_.T_world_first);
    T_world_last_ = options_.T_world_first;
    T_last_velocity_.setIdentity();
    result.T_world_camera = options_.T_world_first;
    result.is_keyframe = true;
    result.timings.total_ms = MsSince(start);
    return result;
  }

  double match_ms = 0, pose_ms = 0;
  const auto Account = [&](const Attempt& a) {
    match_ms += a.match_ms;
    pose_ms += a.pose_ms;
  };
  const Eigen::Isometry3d T_world_predicted = *T_world_last_ * T_last_velocity_;

  const Keyframe* used = &keyframes_.back();
  const Eigen::Isometry3d T_ref_cur_predicted = used->T_world_camera.inverse() * T_world_predicted;
  SEMMAP_ASSIGN_OR_RETURN(Attempt guided, TrackGuided(*used, current, T_ref_cur_predicted));
  Account(guided);
  Attempt best = std::move(guided);
  result.used_guided_matching = true;
  if (Inliers(&best) < options_.min_guided_inliers) {
    SEMMAP_ASSIGN_OR_RETURN(Attempt full, TrackFull(*used, current, T_ref_cur_predicted));
    Account(full);
    if (Inliers(&full) > Inliers(&best)) {
      best = std::move(full);
      result.used_guided_matching = false;
    }
  }
  TrackingState state = TrackingState::kTracking;
  if (!best.estimate) {
    // Relocalisation against the older keyframes, newest first.
    result.used_guided_matching = false;
    const Keyframe* reloc_kf = nullptr;
    Attempt reloc_best;
    for (auto it = keyframes_.rbegin() + 1; it != keyframes_.rend(); ++it) {
      SEMMAP_ASSIGN_OR_RETURN(Attempt a, TrackFull(*it, current, std::nullopt));
      Account(a);
      if (Inliers(&a) > Inliers(&reloc_best)) {
        reloc_best = std::move(a);
        reloc_kf = &*it;
      }
    }
    if (reloc_kf != nullptr) {
      best = std::move(reloc_best);
      used = reloc_kf;
      state = TrackingState::kRelocalised;
    }
  }
  result.num_matches = best.num_matches;

  Eigen::Isometry3d T_world_current = Eigen::Isometry3d::Identity();
  if (best.estimate) {
    T_world_current = used->T_world_camera * best.estimate->T_reference_current;
  }
  if (!best.estimate || !T_world_current.matrix().allFinite()) {
    result.state = TrackingState::kLost;
    result.T_world_camera = *T_world_last_;
    T_last_velocity_.setIdentity();
    result.timings.match_ms = match_ms;
    result.timings.pose_ms = pose_ms;
    result.timings.total_ms = MsSince(start);
    return result;
  }
  result.num_inliers = static_cast<int>(best.estimate->inliers.size());
  result.state = state;
  result.T_world_camera = T_world_current;

  bool make_keyframe = false;
  if (state == TrackingState::kRelocalised) {
    make_keyframe = true;  // track on from here rather than from the reference that failed
  } else {
    Keyframe& ref = keyframes_.back();
    if (ref.tracked_inliers < 0) ref.tracked_inliers = result.num_inliers;
    const bool weak = result.num_inliers < options_.min_inlier_fraction * ref.tracked_inliers;
    make_keyframe = weak;
  }
  if (selector_.Decide(T_world_current)) {
    make_keyframe = true;
  } else if (make_keyframe) {
    selector_ = KeyframeSelector(options_.keyframes);  // restart the motion norm from here
    selector_.Decide(T_world_current);
  }
  if (make_keyframe) MakeKeyframe(std::move(current), T_world_current);
  result.is_keyframe = make_keyframe;

  // After a relocalisation the jump from the last tracked pose is no motion to extrapolate.
  if (state == TrackingState::kRelocalised) {
    T_last_velocity_.setIdentity();
  } else {
    T_last_velocity_ = T_world_last_->inverse() * T_world_current;
  }
  T_world_last_ = T_world_current;
  result.timings.match_ms = match_ms;
  result.timings.pose_ms = pose_ms;
  result.timings.total_ms = MsSince(start);
  return result;
}

}  // namespace semmap
