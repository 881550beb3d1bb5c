#include "core/odometry/rgbd_tracker.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "common/time_util.h"

namespace semmap {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

std::string_view TrackingStateName(TrackingState state) {
  switch (state) {
    case TrackingState::kTracking:
      return "tracking";
    case TrackingState::kRelocalised:
      return "relocalised";
    case TrackingState::kLost:
      return "lost";
    case TrackingState::kReinitialised:
      return "reinitialised";
  }
  return "unknown";
}

Status RgbdTrackerOptions::Validate() const {
  SEMMAP_RETURN_IF_ERROR(ValidateCalibration(camera).WithContext("tracker camera"));
  SEMMAP_RETURN_IF_ERROR(features.Validate());
  SEMMAP_RETURN_IF_ERROR(matcher.Validate());
  SEMMAP_RETURN_IF_ERROR(motion.Validate());
  SEMMAP_RETURN_IF_ERROR(local_map.Validate());
  SEMMAP_RETURN_IF_ERROR(refiner.Validate());
  if (!std::isfinite(map_refine_radius_px) || map_refine_radius_px < 0) {
    return InvalidArgumentError("tracker map_refine_radius_px must be >= 0");
  }
  if (!std::isfinite(map_retry_radius_scale) || map_retry_radius_scale < 1 ||
      map_retry_radius_scale > 10) {
    return InvalidArgumentError("tracker map_retry_radius_scale must be in [1, 10]");
  }
  if (min_guided_inliers < motion.min_inliers) {
    return InvalidArgumentError("tracker min_guided_inliers must be >= motion.min_inliers");
  }
  if (relocalisation_keyframes < 1 || relocalisation_keyframes > 100) {
    return InvalidArgumentError("tracker relocalisation_keyframes must be in [1, 100]");
  }
  if (reinitialise_after_lost < 0) {
    return InvalidArgumentError("tracker reinitialise_after_lost must be >= 0 (0 disables it)");
  }
  if (!T_world_first.matrix().allFinite()) {
    return InvalidArgumentError("tracker T_world_first must be finite");
  }
  return OkStatus();
}

StatusOr<RgbdTracker> RgbdTracker::Create(const RgbdTrackerOptions& options,
                                          std::unique_ptr<KeyframeDecider> keyframes) {
  SEMMAP_RETURN_IF_ERROR(options.Validate());
  if (!keyframes) return InvalidArgumentError("tracker needs a keyframe decider");
  SEMMAP_ASSIGN_OR_RETURN(FeatureExtractor extractor,
                          FeatureExtractor::Create(options.features, options.camera));
  return RgbdTracker(options, std::move(extractor), std::move(keyframes));
}

std::shared_ptr<const FrameFeatures> RgbdTracker::StartSegment(
    FrameFeatures features, const Eigen::Isometry3d& T_world_camera) {
  keyframes_.clear();
  map_.Clear();
  mapped_keyframes_.clear();
  KeyframeCandidate start;
  start.evidence = KeyframeEvidence::kSegmentStart;
  start.T_world_camera = T_world_camera;
  keyframes_decider_->Decide(start);  // always a keyframe: the decider restarts from here
  T_world_last_ = T_world_camera;
  T_last_velocity_.setIdentity();
  lost_with_depth_ = 0;
  return MakeKeyframe(std::move(features), T_world_camera, {});
}

std::shared_ptr<const FrameFeatures> RgbdTracker::MakeKeyframe(
    FrameFeatures features, const Eigen::Isometry3d& T_world_camera,
    const std::vector<int>& point_of_keypoint) {
  map_.AddKeyframe(num_keyframes_, features, T_world_camera, point_of_keypoint,
                   &keyframe_point_ids_);
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
  kf.features = std::make_shared<const FrameFeatures>(std::move(features));
  std::shared_ptr<const FrameFeatures> published = kf.features;
  keyframes_.push_back(std::move(kf));
  while (static_cast<int>(keyframes_.size()) > options_.relocalisation_keyframes) {
    keyframes_.pop_front();
  }
  ++num_keyframes_;
  return published;
}

void RgbdTracker::ApplyCorrection(const Eigen::Isometry3d& T_corrected_world) {
  for (Keyframe& kf : keyframes_) kf.T_world_camera = T_corrected_world * kf.T_world_camera;
  map_.Transform(T_corrected_world);
  for (Eigen::Isometry3d& T_world_keyframe : mapped_keyframes_) {
    T_world_keyframe = T_corrected_world * T_world_keyframe;
  }
  if (T_world_last_) T_world_last_ = T_corrected_world * *T_world_last_;
  // T_last_velocity_ is relative (T_prev_last): unchanged. The decider measures motion from
  // the last keyframe, which moved too.
  keyframes_decider_->ApplyCorrection(T_corrected_world);
}

void RgbdTracker::ApplyMapUpdate(const LocalMapUpdate& update,
                                 const Eigen::Isometry3d& T_new_update) {
  if (num_keyframes_ == 0) return;
  map_.Merge(update, T_new_update, num_keyframes_ - 1);
  mapped_keyframes_.clear();
  for (const Eigen::Isometry3d& T_update_keyframe : update.keyframe_poses_world) {
    mapped_keyframes_.push_back(T_new_update * T_update_keyframe);
  }
}

void RgbdTracker::ProjectMap(const Eigen::Isometry3d& T_world_camera,
                             std::vector<std::optional<cv::Point2f>>* predicted,
                             std::vector<int>* visible) const {
  const Eigen::Isometry3d T_cw = T_world_camera.inverse();
  const CameraCalibration& c = options_.camera;
  predicted->assign(map_.size(), std::nullopt);
  visible->clear();
  for (size_t i = 0; i < map_.size(); ++i) {
    if (map_.point(i).retired) continue;
    const Eigen::Vector3d p = T_cw * map_.point(i).position_world;
    if (!(p.z() > options_.features.min_depth_m) || p.z() > options_.features.max_depth_m) continue;
    const double u = c.fx * p.x() / p.z() + c.cx, v = c.fy * p.y() / p.z() + c.cy;
    if (u < 0 || v < 0 || u > c.width - 1 || v > c.height - 1) continue;
    (*predicted)[i] = cv::Point2f(static_cast<float>(u), static_cast<float>(v));
    visible->push_back(static_cast<int>(i));
  }
}

StatusOr<std::optional<RgbdTracker::MapPass>> RgbdTracker::MatchAndEstimate(
    const FrameFeatures& current, const std::vector<std::optional<cv::Point2f>>& predicted,
    const Eigen::Isometry3d& T_world_guess, const FeatureMatcherOptions& matcher, double* match_ms,
    double* pose_ms) const {
  Clock::time_point start = Clock::now();
  MapPass pass;
  SEMMAP_ASSIGN_OR_RETURN(
      pass.matches,
      MatchGuided(map_.descriptors(), predicted, current.descriptors, current.keypoints, matcher));
  *match_ms += MillisecondsSince(start);
  if (static_cast<int>(pass.matches.size()) < options_.motion.min_matches) {
    return std::optional<MapPass>();
  }
  start = Clock::now();
  std::vector<Eigen::Vector3d> points;
  std::vector<cv::Point2f> pixels;
  points.reserve(pass.matches.size());
  pixels.reserve(pass.matches.size());
  for (const cv::DMatch& m : pass.matches) {
    points.push_back(map_.point(static_cast<size_t>(m.queryIdx)).position_world);
    pixels.push_back(current.keypoints[static_cast<size_t>(m.trainIdx)].pt);
  }
  StatusOr<MotionEstimate> initial =
      EstimateMotion(points, pixels, options_.camera, options_.motion, T_world_guess);
  if (!initial.ok()) {
    *pose_ms += MillisecondsSince(start);
    if (initial.status().code() == StatusCode::kFailedPrecondition) {
      return std::optional<MapPass>();
    }
    return initial.status();
  }
  pass.refined = RefinePoseRgbd(ObservationsOf(current, pass.matches), options_.camera,
                                options_.refiner, initial->T_reference_current.inverse());
  *pose_ms += MillisecondsSince(start);
  return std::optional<MapPass>(std::move(pass));
}

std::vector<RgbdObservation> RgbdTracker::ObservationsOf(
    const FrameFeatures& current, const std::vector<cv::DMatch>& matches) const {
  const double scale = options_.local_map.octave_scale;
  const double pixel_sigma = options_.local_map.pixel_sigma;
  std::vector<RgbdObservation> obs(matches.size());
  for (size_t m = 0; m < matches.size(); ++m) {
    const size_t k = static_cast<size_t>(matches[m].trainIdx);
    RgbdObservation& o = obs[m];
    o.point = map_.point(static_cast<size_t>(matches[m].queryIdx)).position_world;
    o.pixel = Eigen::Vector2d(current.keypoints[k].pt.x, current.keypoints[k].pt.y);
    o.pixel_sigma = pixel_sigma * std::pow(scale, current.keypoints[k].octave);
    o.inverse_depth = current.has_depth[k] ? 1.0 / current.points_camera[k].z() : 0.0;
  }
  return obs;
}

StatusOr<std::optional<RgbdTracker::Solution>> RgbdTracker::TrackLocalMap(
    const FrameFeatures& current, const Eigen::Isometry3d& T_world_guess, double radius_px,
    double* match_ms, double* pose_ms) const {
  if (map_.size() == 0 || current.size() == 0) return std::optional<Solution>();
  FeatureMatcherOptions search = options_.matcher;
  search.guided_radius_px = radius_px;
  Solution sol;
  std::vector<std::optional<cv::Point2f>> predicted;
  ProjectMap(T_world_guess, &predicted, &sol.visible);

  // The prediction's wide search first looks for the points the last frame found (ORB-SLAM2's
  // motion-model step): a few hundred reliable points instead of every point in view, where
  // the wide radius costs most. The second, tight projection at the pose they give then takes
  // in the whole map. Too few of them (after a lost frame or a new segment the last frame
  // found none), or no pose from them: every point in view, as for the first frame.
  std::optional<MapPass> pass;
  bool whole_map = true;
  if (options_.search_last_frame_points_first && options_.map_refine_radius_px > 0) {
    std::vector<std::optional<cv::Point2f>> recent(predicted.size());
    int num_recent = 0;
    for (int i : sol.visible) {
      const size_t p = static_cast<size_t>(i);
      if (map_.point(p).last_found_frame != frame_number_ - 1) continue;
      recent[p] = predicted[p];
      ++num_recent;
    }
    if (num_recent >= options_.min_guided_inliers) {
      SEMMAP_ASSIGN_OR_RETURN(
          pass, MatchAndEstimate(current, recent, T_world_guess, search, match_ms, pose_ms));
      whole_map = false;
      if (pass && pass->refined.num_inliers < options_.motion.min_inliers) pass.reset();
    }
  }
  if (!pass) {
    SEMMAP_ASSIGN_OR_RETURN(
        pass, MatchAndEstimate(current, predicted, T_world_guess, search, match_ms, pose_ms));
    whole_map = true;
  }
  if (!pass) return std::optional<Solution>();
  RgbdRefinement refined = std::move(pass->refined);
  std::vector<cv::DMatch> matches = std::move(pass->matches);
  sol.num_matches = static_cast<int>(matches.size());

  if (options_.map_refine_radius_px > 0 && refined.num_inliers >= options_.motion.min_inliers) {
    std::vector<int> visible;
    ProjectMap(refined.T_current_reference.inverse(), &predicted, &visible);
    FeatureMatcherOptions tight = options_.matcher;
    tight.guided_radius_px = options_.map_refine_radius_px;
    Clock::time_point start = Clock::now();
    SEMMAP_ASSIGN_OR_RETURN(
        std::vector<cv::DMatch> more,
        MatchGuided(map_.descriptors(), predicted, current.descriptors, current.keypoints, tight));
    *match_ms += MillisecondsSince(start);
    start = Clock::now();
    RgbdRefinement second = RefinePoseRgbd(ObservationsOf(current, more), options_.camera,
                                           options_.refiner, refined.T_current_reference);
    *pose_ms += MillisecondsSince(start);
    // After a pass over the last frame's points only, the whole map's pass is the estimate
    // whenever it holds (its inliers include most of those points).
    const bool take = whole_map ? second.num_inliers >= refined.num_inliers
                                : second.num_inliers >= options_.motion.min_inliers;
    if (take) {
      refined = std::move(second);
      matches = std::move(more);
      sol.visible = std::move(visible);
      sol.num_matches = static_cast<int>(matches.size());
    }
  }
  if (refined.num_inliers < options_.motion.min_inliers ||
      !refined.T_current_reference.matrix().allFinite() || !refined.information.allFinite()) {
    return std::optional<Solution>();
  }
  sol.T_world_current = refined.T_current_reference.inverse();
  sol.information = refined.information;
  sol.num_inliers = refined.num_inliers;
  sol.point_of_keypoint.assign(current.size(), -1);
  for (size_t m = 0; m < matches.size(); ++m) {
    if (!refined.inlier[m]) continue;
    sol.point_of_keypoint[static_cast<size_t>(matches[m].trainIdx)] = matches[m].queryIdx;
    sol.found.push_back(matches[m].queryIdx);
  }
  return std::optional<Solution>(std::move(sol));
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
            ->points_camera[static_cast<size_t>(kf.depth_index[static_cast<size_t>(m.queryIdx)])]);
    pixels.push_back(current.keypoints[static_cast<size_t>(m.trainIdx)].pt);
  }
  Attempt attempt;
  attempt.num_matches = static_cast<int>(matches.size());
  const Clock::time_point start = Clock::now();
  StatusOr<MotionEstimate> estimate =
      EstimateMotion(points, pixels, options_.camera, options_.motion, guess);
  attempt.pose_ms = MillisecondsSince(start);
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
        T_cur_ref * kf.features->points_camera[static_cast<size_t>(kf.depth_index[r])];
    if (!(p.z() > 0.05)) continue;
    const double u = c.fx * p.x() / p.z() + c.cx, v = c.fy * p.y() / p.z() + c.cy;
    if (u < -10 || v < -10 || u > c.width + 10 || v > c.height + 10) continue;
    predicted[r] = cv::Point2f(static_cast<float>(u), static_cast<float>(v));
  }
  const Clock::time_point start = Clock::now();
  SEMMAP_ASSIGN_OR_RETURN(std::vector<cv::DMatch> matches,
                          MatchGuided(kf.depth_descriptors, predicted, current.descriptors,
                                      current.keypoints, options_.matcher));
  const double match_ms = MillisecondsSince(start);
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
  const double match_ms = MillisecondsSince(start);
  SEMMAP_ASSIGN_OR_RETURN(Attempt attempt, Estimate(kf, current, matches, guess));
  attempt.match_ms = match_ms;
  return attempt;
}

StatusOr<TrackingResult> RgbdTracker::Track(const cv::Mat& image, const DecodedDepth& depth,
                                            int64_t stamp_ns) {
  const Clock::time_point start = Clock::now();
  const auto inliers_of = [](const Attempt* a) {
    return a->estimate ? static_cast<int>(a->estimate->inliers.size()) : -1;
  };
  if (last_stamp_ns_ && stamp_ns <= *last_stamp_ns_) {
    return InvalidArgumentError("frame stamps must increase (" + std::to_string(stamp_ns) +
                                " after " + std::to_string(*last_stamp_ns_) + ")");
  }
  TrackingResult result;
  ++frame_number_;
  SEMMAP_ASSIGN_OR_RETURN(FrameFeatures current,
                          extractor_.Extract(image, depth.raw, depth.depth_scale));
  result.timings.extract_ms = MillisecondsSince(start);
  last_stamp_ns_ = stamp_ns;

  const bool has_depth = !depth.raw.empty();
  if (keyframes_.empty() && !has_depth) {
    // Nothing to track against, and no 3D points to start a map from.
    result.state = TrackingState::kLost;
    result.T_world_camera = options_.T_world_first;
    result.timings.total_ms = MillisecondsSince(start);
    return result;
  }
  if (keyframes_.empty()) {
    result.keyframe_features = StartSegment(std::move(current), options_.T_world_first);
    result.keyframe_point_ids = std::move(keyframe_point_ids_);
    result.T_world_camera = options_.T_world_first;
    result.is_keyframe = true;
    result.timings.total_ms = MillisecondsSince(start);
    return result;
  }

  double match_ms = 0, pose_ms = 0;
  const auto account = [&](const Attempt& a) {
    match_ms += a.match_ms;
    pose_ms += a.pose_ms;
  };
  const auto from_attempt = [](const Keyframe& kf, const Attempt& a) {
    Solution sol;
    sol.T_world_current = kf.T_world_camera * a.estimate->T_reference_current;
    sol.information = a.estimate->information;
    sol.num_matches = a.num_matches;
    sol.num_inliers = static_cast<int>(a.estimate->inliers.size());
    return sol;
  };
  const Eigen::Isometry3d T_world_predicted = *T_world_last_ * T_last_velocity_;

  // 1. The local map around the prediction; when that finds too little, around the last pose,
  // then with a wider search (RgbdTrackerOptions::map_retries).
  const double radius_px = options_.matcher.guided_radius_px;
  SEMMAP_ASSIGN_OR_RETURN(
      std::optional<Solution> best,
      TrackLocalMap(current, T_world_predicted, radius_px, &match_ms, &pose_ms));
  const auto weak = [&] {
    return options_.map_retries && (!best || best->num_inliers < options_.min_guided_inliers);
  };
  const auto retry = [&](const Eigen::Isometry3d& T_world_guess, double radius) -> Status {
    SEMMAP_ASSIGN_OR_RETURN(std::optional<Solution> again,
                            TrackLocalMap(current, T_world_guess, radius, &match_ms, &pose_ms));
    if (again && (!best || again->num_inliers > best->num_inliers)) best = std::move(again);
    return OkStatus();
  };
  if (weak() && !T_last_velocity_.isApprox(Eigen::Isometry3d::Identity())) {
    SEMMAP_RETURN_IF_ERROR(retry(*T_world_last_, radius_px));
  }
  if (weak() && options_.map_retry_radius_scale > 1) {  // 1: the same search again
    SEMMAP_RETURN_IF_ERROR(retry(T_world_predicted, radius_px * options_.map_retry_radius_scale));
  }
  result.used_guided_matching = best.has_value();
  int last_matches = best ? best->num_matches : 0;
  TrackingState state = TrackingState::kTracking;
  // 2. Too little support: the reference keyframe directly (guided, then full matching), and
  // the map again from the pose found.
  if (!best || best->num_inliers < options_.min_guided_inliers) {
    const Keyframe& ref = keyframes_.back();
    const Eigen::Isometry3d T_ref_cur_predicted = ref.T_world_camera.inverse() * T_world_predicted;
    SEMMAP_ASSIGN_OR_RETURN(Attempt attempt, TrackGuided(ref, current, T_ref_cur_predicted));
    account(attempt);
    bool guided = true;
    if (inliers_of(&attempt) < options_.min_guided_inliers) {
      SEMMAP_ASSIGN_OR_RETURN(Attempt full, TrackFull(ref, current, T_ref_cur_predicted));
      account(full);
      if (inliers_of(&full) > inliers_of(&attempt)) {
        attempt = std::move(full);
        guided = false;
      }
    }
    last_matches = std::max(last_matches, attempt.num_matches);
    const Keyframe* used = &ref;
    if (!attempt.estimate && !best) {
      // 3. Relocalisation against the older keyframes, newest first.
      for (auto it = keyframes_.rbegin() + 1; it != keyframes_.rend(); ++it) {
        SEMMAP_ASSIGN_OR_RETURN(Attempt a, TrackFull(*it, current, std::nullopt));
        account(a);
        if (inliers_of(&a) > inliers_of(&attempt)) {
          attempt = std::move(a);
          used = &*it;
        }
      }
      if (attempt.estimate) state = TrackingState::kRelocalised;
      guided = false;
    }
    if (attempt.estimate) {
      Solution from_keyframe = from_attempt(*used, attempt);
      SEMMAP_ASSIGN_OR_RETURN(
          std::optional<Solution> again,
          TrackLocalMap(current, from_keyframe.T_world_current, radius_px, &match_ms, &pose_ms));
      std::optional<Solution> candidate =
          again && again->num_inliers >= from_keyframe.num_inliers / 2 ? std::move(again)
                                                                       : std::move(from_keyframe);
      if (!best || candidate->num_inliers > best->num_inliers) {
        best = std::move(candidate);
        result.used_guided_matching = guided;
      } else {
        state = TrackingState::kTracking;
      }
    }
  }
  result.num_matches = best ? best->num_matches : last_matches;

  if (!best || !best->T_world_current.matrix().allFinite()) {
    result.state = TrackingState::kLost;
    result.T_world_camera = *T_world_last_;
    T_last_velocity_.setIdentity();
    if (has_depth) {
      // Lost for long enough: the kept keyframes are out of reach. A frame good enough to
      // track from starts a new segment at the last known pose; a poor one stays lost.
      const int n = options_.reinitialise_after_lost;
      const size_t min_depth_keypoints = 2 * static_cast<size_t>(options_.motion.min_inliers);
      if (n > 0 && lost_with_depth_ >= n && current.NumWithDepth() >= min_depth_keypoints) {
        result.keyframe_features = StartSegment(std::move(current), *T_world_last_);
        result.keyframe_point_ids = std::move(keyframe_point_ids_);
        result.state = TrackingState::kReinitialised;
        result.new_segment = true;
        result.is_keyframe = true;
      } else if (lost_with_depth_ < std::numeric_limits<int>::max()) {
        ++lost_with_depth_;
      }
    }
    result.timings.match_ms = match_ms;
    result.timings.pose_ms = pose_ms;
    result.timings.total_ms = MillisecondsSince(start);
    return result;
  }
  const Eigen::Isometry3d T_world_current = best->T_world_current;
  lost_with_depth_ = 0;
  result.num_inliers = best->num_inliers;
  result.state = state;
  result.T_world_camera = T_world_current;
  result.information = best->information;
  map_.CountTracked(best->visible, best->found, frame_number_);

  // A frame without depth is tracked (PnP needs no depth of its own); the decider never makes
  // it a keyframe, and the next frame with depth decides.
  KeyframeCandidate candidate;
  candidate.evidence = state == TrackingState::kRelocalised ? KeyframeEvidence::kRelocalised
                                                            : KeyframeEvidence::kTracked;
  candidate.T_world_camera = T_world_current;
  candidate.has_depth = has_depth;
  candidate.num_inliers = result.num_inliers;
  candidate.mapped_keyframes = &mapped_keyframes_;
  const bool make_keyframe = keyframes_decider_->Decide(candidate);
  if (make_keyframe) {
    result.keyframe_features =
        MakeKeyframe(std::move(current), T_world_current, best->point_of_keypoint);
    result.keyframe_point_ids = std::move(keyframe_point_ids_);
  }
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
  result.timings.total_ms = MillisecondsSince(start);
  return result;
}

}  // namespace semmap
