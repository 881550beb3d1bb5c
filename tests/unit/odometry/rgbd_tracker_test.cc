#include "core/odometry/rgbd_tracker.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cstdio>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <utility>
#include <vector>

#include "client/datasets/dataset.h"
#include "client/eval/ate.h"
#include "core/slam/keyframe_policy.h"
#include "tests/testing/temp_dir.h"
#include "tests/unit/odometry/odometry_test_util.h"

namespace semmap {
namespace {

using odometry_test::Circle;
using odometry_test::MakeRenderer;

// The tracker with the keyframe rule the pipeline gives it (core/slam/keyframe_policy.h).
StatusOr<RgbdTracker> CreateTracker(const RgbdTrackerOptions& options) {
  return RgbdTracker::Create(options, std::make_unique<KeyframePolicy>(KeyframePolicyOptions{}));
}

RgbdTracker MakeTracker(const CameraCalibration& camera, RgbdTrackerOptions options = {}) {
  options.camera = camera;
  StatusOr<RgbdTracker> t = CreateTracker(options);
  EXPECT_TRUE(t.ok()) << t.status().ToString();
  return std::move(t).value();
}

DecodedDepth Depth(const cv::Mat& raw, double scale) {
  DecodedDepth d;
  d.raw = raw;
  d.depth_scale = scale;
  return d;
}

// `frames` poses of quick handheld motion through the default room.
std::vector<StampedPose> FastMotion(int frames) {
  synth::TrajectoryOptions trajectory;
  trajectory.frames = frames;
  StatusOr<std::vector<StampedPose>> poses =
      synth::FastMotionTrajectory(odometry_test::Room().room, trajectory);
  EXPECT_TRUE(poses.ok()) << poses.status().ToString();
  return poses.ok() ? std::move(poses).value() : std::vector<StampedPose>{};
}

TEST(RgbdTrackerTest, SyntheticCircleAteUnderTwoCentimetres) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  const synth::Renderer renderer = MakeRenderer(camera);
  const std::vector<StampedPose> gt = Circle(120);
  RgbdTrackerOptions options;
  options.T_world_first = gt.front().T_world_camera;
  RgbdTracker tracker = MakeTracker(camera, options);
  std::vector<StampedPose> estimate;
  int keyframes = 0;
  for (const StampedPose& p : gt) {
    const synth::RenderedFrame f = renderer.Render(p.T_world_camera);
    StatusOr<TrackingResult> r =
        tracker.Track(f.bgr, Depth(f.depth, synth::kDepthScale), p.stamp_ns);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    ASSERT_EQ(r->state, TrackingState::kTracking) << "frame " << estimate.size();
    ASSERT_TRUE(r->T_world_camera.matrix().allFinite());
    keyframes += r->is_keyframe ? 1 : 0;
    estimate.push_back({p.stamp_ns, r->T_world_camera});
  }
  StatusOr<AteResult> ate = ComputeAte(gt, estimate);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  std::printf("synthetic circle (120 frames, 640x480): ATE RMSE %.4f m, max %.4f m, %d keyframes\n",
              ate->stats.rmse, ate->stats.max, keyframes);
  EXPECT_LT(ate->stats.rmse, 0.02);
  EXPECT_GT(keyframes, 5);
  EXPECT_LT(keyframes, 80);
  // Seeded with the true first pose, the raw estimate (no alignment) stays close too.
  EXPECT_LT((estimate.back().T_world_camera.translation() - gt.back().T_world_camera.translation())
                .norm(),
            0.1);
}

// The wide search over the last frame's points first is a saving, not a different estimate:
// on fast motion every frame tracks either way, and the poses agree with those of the wide
// search over the whole map to within millimetres (and match the truth as well).
TEST(RgbdTrackerTest, SearchingTheLastFramesPointsFirstKeepsThePoses) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  const synth::Renderer renderer = MakeRenderer(camera);
  const std::vector<StampedPose> gt = FastMotion(90);
  std::vector<synth::RenderedFrame> frames;
  frames.reserve(gt.size());
  for (const StampedPose& p : gt) frames.push_back(renderer.Render(p.T_world_camera));
  std::vector<std::vector<StampedPose>> estimates;
  for (const bool recent_first : {true, false}) {
    RgbdTrackerOptions options;
    options.T_world_first = gt.front().T_world_camera;
    options.search_last_frame_points_first = recent_first;
    RgbdTracker tracker = MakeTracker(camera, options);
    std::vector<StampedPose>& estimate = estimates.emplace_back();
    for (size_t i = 0; i < gt.size(); ++i) {
      StatusOr<TrackingResult> r =
          tracker.Track(frames[i].bgr, Depth(frames[i].depth, synth::kDepthScale), gt[i].stamp_ns);
      ASSERT_TRUE(r.ok()) << r.status().ToString();
      ASSERT_EQ(r->state, TrackingState::kTracking) << "frame " << i << " recent " << recent_first;
      estimate.push_back({gt[i].stamp_ns, r->T_world_camera});
    }
  }
  double max_offset_m = 0, max_angle_deg = 0;
  for (size_t i = 0; i < gt.size(); ++i) {
    const Eigen::Isometry3d d =
        estimates[1][i].T_world_camera.inverse() * estimates[0][i].T_world_camera;
    max_offset_m = std::max(max_offset_m, d.translation().norm());
    max_angle_deg = std::max(max_angle_deg, odometry_test::AngleDeg(d));
  }
  StatusOr<AteResult> recent = ComputeAte(gt, estimates[0]);
  StatusOr<AteResult> whole = ComputeAte(gt, estimates[1]);
  ASSERT_TRUE(recent.ok() && whole.ok());
  std::printf(
      "last frame's points first vs whole map: ATE %.4f vs %.4f m, poses differ by at most "
      "%.4f m / %.3f deg\n",
      recent->stats.rmse, whole->stats.rmse, max_offset_m, max_angle_deg);
  EXPECT_LT(max_offset_m, 0.002);
  EXPECT_LT(max_angle_deg, 0.1);
  EXPECT_LT(recent->stats.rmse, whole->stats.rmse + 0.001);
}

// A depth dropout: the frame is tracked from 2D features and never becomes a keyframe; with
// no keyframe yet it cannot be placed at all.
TEST(RgbdTrackerTest, FramesWithoutDepthAreTrackedButNeverKeyframes) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  const synth::Renderer renderer = MakeRenderer(camera);
  const std::vector<StampedPose> gt = odometry_test::Circle(240);  // 1.5 degrees per frame
  RgbdTrackerOptions options;
  options.T_world_first = gt[1].T_world_camera;  // the first frame with depth starts the map
  RgbdTracker tracker = MakeTracker(camera, options);
  const DecodedDepth none;
  const synth::RenderedFrame first = renderer.Render(gt[0].T_world_camera);
  StatusOr<TrackingResult> r = tracker.Track(first.bgr, none, gt[0].stamp_ns);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->state, TrackingState::kLost);
  EXPECT_FALSE(r->is_keyframe);
  for (size_t i = 1; i < 30; ++i) {
    const synth::RenderedFrame f = renderer.Render(gt[i].T_world_camera);
    // Frames 10..19 have no depth, across the motion a keyframe would normally be taken in.
    const bool dropout = i >= 10 && i < 20;
    r = tracker.Track(f.bgr, dropout ? none : Depth(f.depth, synth::kDepthScale), gt[i].stamp_ns);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    EXPECT_NE(r->state, TrackingState::kLost) << "frame " << i;
    if (dropout) {
      EXPECT_FALSE(r->is_keyframe) << "frame " << i;
    }
    EXPECT_LT((r->T_world_camera.translation() - gt[i].T_world_camera.translation()).norm(), 0.02)
        << "frame " << i;
  }
}

// Quick handheld motion (1.5-3 m/s, up to ~200 deg/s at 30 Hz): tracked throughout.
TEST(RgbdTrackerTest, SyntheticFastMotionTracksEveryFrame) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  const synth::Renderer renderer = MakeRenderer(camera);
  const std::vector<StampedPose> gt = FastMotion(90);
  RgbdTrackerOptions options;
  options.T_world_first = gt.front().T_world_camera;
  RgbdTracker tracker = MakeTracker(camera, options);
  std::vector<StampedPose> estimate;
  int lost = 0;
  for (const StampedPose& p : gt) {
    const synth::RenderedFrame f = renderer.Render(p.T_world_camera);
    StatusOr<TrackingResult> r =
        tracker.Track(f.bgr, Depth(f.depth, synth::kDepthScale), p.stamp_ns);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    ASSERT_TRUE(r->T_world_camera.matrix().allFinite());
    lost += r->state == TrackingState::kLost ? 1 : 0;
    estimate.push_back({p.stamp_ns, r->T_world_camera});
  }
  StatusOr<AteResult> ate = ComputeAte(gt, estimate);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  std::printf("synthetic fast motion (90 frames, 640x480): ATE RMSE %.4f m, max %.4f m, %d lost\n",
              ate->stats.rmse, ate->stats.max, lost);
  EXPECT_EQ(lost, 0);
  EXPECT_LT(ate->stats.rmse, 0.03);
}

TEST(RgbdTrackerTest, LosesTrackOnABlankFrameAndRelocalisesAgainstAnOlderKeyframe) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera(320, 240);
  const synth::Renderer renderer = MakeRenderer(camera);
  const std::vector<StampedPose> gt = Circle(120);
  RgbdTrackerOptions options;
  options.T_world_first = gt.front().T_world_camera;
  options.relocalisation_keyframes = 30;
  RgbdTracker tracker = MakeTracker(camera, options);
  auto track = [&](const cv::Mat& bgr, const cv::Mat& depth, int64_t stamp) {
    StatusOr<TrackingResult> r = tracker.Track(bgr, Depth(depth, synth::kDepthScale), stamp);
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    EXPECT_TRUE(r.ok() && r->T_world_camera.matrix().allFinite());
    return r.ok() ? *r : TrackingResult{};
  };
  // A quarter turn (90 degrees of heading): the reference ends up facing another wall.
  for (size_t i = 0; i <= 30; ++i) {
    const synth::RenderedFrame f = renderer.Render(gt[i].T_world_camera);
    ASSERT_EQ(track(f.bgr, f.depth, gt[i].stamp_ns).state, TrackingState::kTracking) << i;
  }
  // A covered lens: no features at all. Lost, and the last pose is reported.
  const TrackingResult lost = track(cv::Mat(240, 320, CV_8UC3, cv::Scalar(0, 0, 0)),
                                    cv::Mat(240, 320, CV_16UC1, cv::Scalar(0)), gt[31].stamp_ns);
  EXPECT_EQ(lost.state, TrackingState::kLost);
  EXPECT_FALSE(lost.is_keyframe);
  EXPECT_TRUE(lost.T_world_camera.isApprox(gt[30].T_world_camera, 0.05));
  // The camera is back where it started: only an older keyframe sees this view.
  const synth::RenderedFrame back = renderer.Render(gt[2].T_world_camera);
  const TrackingResult again = track(back.bgr, back.depth, gt[32].stamp_ns);
  EXPECT_EQ(again.state, TrackingState::kRelocalised);
  EXPECT_TRUE(again.is_keyframe);
  const Eigen::Isometry3d error = gt[2].T_world_camera.inverse() * again.T_world_camera;
  EXPECT_LT(error.translation().norm(), 0.03);
  // And tracking goes on from there.
  const synth::RenderedFrame next = renderer.Render(gt[3].T_world_camera);
  EXPECT_EQ(track(next.bgr, next.depth, gt[33].stamp_ns).state, TrackingState::kTracking);
}

// Keyframes every `every` frames until frame `until`, none after: a revisit over a mapped
// place (KeyframePolicyOptions::skip_mapped_views) leaves the reference keyframe behind.
class KeyframesUntil final : public KeyframeDecider {
 public:
  KeyframesUntil(int every, int until) : every_(every), until_(until) {}
  bool Decide(const KeyframeCandidate& candidate) override {
    const int frame = frame_++;
    return candidate.evidence == KeyframeEvidence::kSegmentStart ||
           (frame < until_ && frame % every_ == 0);
  }
  void ApplyCorrection(const Eigen::Isometry3d& /*T_corrected_world*/) override {}

 private:
  int every_, until_, frame_ = 0;
};

// Half a lap into a second lap that makes no keyframes, the camera stops for a frame (a
// repeated frame does the same) and goes on: the constant-velocity guess is wrong twice (at
// the stop and at the restart) and the reference keyframe faces the other way. The map around
// the last pose and the wider search keep every frame tracked; without them both are lost.
TEST(RgbdTrackerTest, AStopOnARevisitIsTrackedFromTheMap) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera(320, 240);
  const synth::Renderer renderer = MakeRenderer(camera);
  synth::TrajectoryOptions trajectory;
  trajectory.frames = 240;
  trajectory.laps = 2;
  StatusOr<std::vector<StampedPose>> lap =
      synth::CircleTrajectory(odometry_test::Room().room, trajectory);
  ASSERT_TRUE(lap.ok()) << lap.status().ToString();
  std::vector<size_t> order;  // frames of the trajectory, frame 180 twice
  for (size_t i = 0; i <= 185; ++i) {
    order.push_back(i);
    if (i == 180) order.push_back(i);
  }
  std::vector<synth::RenderedFrame> frames;
  for (size_t i = 0; i <= 185; ++i) frames.push_back(renderer.Render((*lap)[i].T_world_camera));
  for (const bool retries : {true, false}) {
    RgbdTrackerOptions options;
    options.camera = camera;
    options.T_world_first = lap->front().T_world_camera;
    options.local_map.window_keyframes = 60;  // the first lap's keyframes all stay
    options.map_retries = retries;
    StatusOr<RgbdTracker> tracker =
        RgbdTracker::Create(options, std::make_unique<KeyframesUntil>(3, 120));
    ASSERT_TRUE(tracker.ok()) << tracker.status().ToString();
    int lost = 0;
    double worst_m = 0;
    for (size_t k = 0; k < order.size(); ++k) {
      const synth::RenderedFrame& f = frames[order[k]];
      StatusOr<TrackingResult> r = tracker->Track(f.bgr, Depth(f.depth, synth::kDepthScale),
                                                  static_cast<int64_t>(k + 1) * 33'333'333);
      ASSERT_TRUE(r.ok()) << r.status().ToString();
      if (r->state == TrackingState::kLost) {
        ++lost;
        continue;
      }
      if (retries) {
        ASSERT_EQ(r->state, TrackingState::kTracking) << "frame " << order[k];
      }
      worst_m = std::max(
          worst_m,
          (r->T_world_camera.translation() - (*lap)[order[k]].T_world_camera.translation()).norm());
    }
    std::printf("stop on a revisit, map retries %s: %d lost, worst tracked frame %.4f m off\n",
                retries ? "on" : "off", lost, worst_m);
    if (retries) {
      EXPECT_EQ(lost, 0);
      EXPECT_LT(worst_m, 0.02);
    } else {
      EXPECT_GT(lost, 0);  // the scene above is the one the retries are for
    }
  }
}

TEST(RgbdTrackerTest, PublishesKeyframeFeaturesAndInformation) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera(320, 240);
  const synth::Renderer renderer = MakeRenderer(camera);
  const std::vector<StampedPose> gt = Circle(120);
  RgbdTracker tracker = MakeTracker(camera);
  for (size_t i = 0; i < 20; ++i) {
    const synth::RenderedFrame f = renderer.Render(gt[i].T_world_camera);
    StatusOr<TrackingResult> r =
        tracker.Track(f.bgr, Depth(f.depth, synth::kDepthScale), gt[i].stamp_ns);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    ASSERT_EQ(r->state, TrackingState::kTracking) << i;
    EXPECT_EQ(r->is_keyframe, r->keyframe_features != nullptr) << i;
    if (r->keyframe_features) {
      EXPECT_GT(r->keyframe_features->NumWithDepth(), 50u) << i;
    }
    if (i == 0) {
      EXPECT_TRUE(r->information.isZero()) << "the first frame has no estimate";
    } else {
      // Positive definite: every direction of the 6-DoF pose is observed.
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eigen(r->information);
      EXPECT_GT(eigen.eigenvalues().minCoeff(), 0) << i;
      EXPECT_TRUE(r->information.isApprox(r->information.transpose())) << i;
    }
  }
  EXPECT_GT(tracker.num_map_points(), 100u);
}

// After ApplyCorrection(T), the tracker continues in the corrected frame: the next poses are
// T times those an uncorrected twin reports on the same frames.
TEST(RgbdTrackerTest, ApplyCorrectionReexpressesTrackingInTheCorrectedFrame) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera(320, 240);
  const synth::Renderer renderer = MakeRenderer(camera);
  const std::vector<StampedPose> gt = Circle(120);
  RgbdTrackerOptions options;
  options.T_world_first = gt.front().T_world_camera;
  RgbdTracker plain = MakeTracker(camera, options);
  RgbdTracker corrected = MakeTracker(camera, options);
  Eigen::Isometry3d T_corrected_world = Eigen::Isometry3d::Identity();
  T_corrected_world.linear() =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 0.1, 1.0).normalized()).toRotationMatrix();
  T_corrected_world.translation() = Eigen::Vector3d(0.5, -0.2, 0.1);
  int keyframes_after = 0;
  for (size_t i = 0; i < 40; ++i) {
    if (i == 15) corrected.ApplyCorrection(T_corrected_world);
    const synth::RenderedFrame f = renderer.Render(gt[i].T_world_camera);
    StatusOr<TrackingResult> a =
        plain.Track(f.bgr, Depth(f.depth, synth::kDepthScale), gt[i].stamp_ns);
    StatusOr<TrackingResult> b =
        corrected.Track(f.bgr, Depth(f.depth, synth::kDepthScale), gt[i].stamp_ns);
    ASSERT_TRUE(a.ok() && b.ok());
    ASSERT_EQ(a->state, TrackingState::kTracking) << i;
    ASSERT_EQ(b->state, TrackingState::kTracking) << i;
    const Eigen::Isometry3d expected =
        i < 15 ? a->T_world_camera : T_corrected_world * a->T_world_camera;
    const Eigen::Isometry3d error = expected.inverse() * b->T_world_camera;
    EXPECT_LT(error.translation().norm(), 1e-4) << i;
    EXPECT_LT(odometry_test::AngleDeg(error), 1e-3) << i;
    EXPECT_EQ(a->is_keyframe, b->is_keyframe) << i;
    if (i >= 15) keyframes_after += b->is_keyframe ? 1 : 0;
  }
  EXPECT_GT(keyframes_after, 0) << "the corrected keyframe poses were used too";
}

// Feeds frames to a tracker with increasing stamps (1/30 s apart) and checks every call.
class Feeder {
 public:
  Feeder(const CameraCalibration& camera, const synth::Renderer& renderer,
         RgbdTrackerOptions options)
      : camera_(camera), renderer_(renderer), tracker_(MakeTracker(camera, std::move(options))) {}

  TrackingResult Pose(const Eigen::Isometry3d& T_world_camera, bool with_depth = true) {
    const synth::RenderedFrame f = renderer_.Render(T_world_camera);
    return Feed(f.bgr, with_depth ? f.depth : cv::Mat());
  }
  // A covered lens: black, and depth with no valid pixel.
  TrackingResult Blank() {
    return Feed(cv::Mat(camera_.height, camera_.width, CV_8UC3, cv::Scalar(0, 0, 0)),
                cv::Mat(camera_.height, camera_.width, CV_16UC1, cv::Scalar(0)));
  }
  RgbdTracker& tracker() { return tracker_; }

 private:
  TrackingResult Feed(const cv::Mat& bgr, const cv::Mat& depth) {
    stamp_ns_ += 33'333'333;
    StatusOr<TrackingResult> r = tracker_.Track(
        bgr, depth.empty() ? DecodedDepth{} : Depth(depth, synth::kDepthScale), stamp_ns_);
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    if (!r.ok()) return TrackingResult{};
    EXPECT_TRUE(r->T_world_camera.matrix().allFinite());
    return *r;
  }

  CameraCalibration camera_;
  const synth::Renderer& renderer_;
  RgbdTracker tracker_;
  int64_t stamp_ns_ = 1'000'000'000;
};

// Frames 0..19 of the circle, then a cut to the far side (frames 60.., 180 degrees of heading
// away): neither the local map nor the kept keyframes see it. After reinitialise_after_lost
// lost frames the next one starts a new segment at the last pose, and tracking goes on from
// there with the right relative motion.
TEST(RgbdTrackerTest, SustainedLossStartsANewSegmentThatTracksTheRelativeMotion) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera(320, 240);
  const synth::Renderer renderer = MakeRenderer(camera);
  const std::vector<StampedPose> gt = Circle(120);
  RgbdTrackerOptions options;
  options.T_world_first = gt.front().T_world_camera;
  ASSERT_EQ(options.reinitialise_after_lost, 5);
  Feeder feed(camera, renderer, options);
  Eigen::Isometry3d T_world_last = Eigen::Isometry3d::Identity();
  for (size_t i = 0; i < 20; ++i) {
    const TrackingResult r = feed.Pose(gt[i].T_world_camera);
    ASSERT_EQ(r.state, TrackingState::kTracking) << i;
    EXPECT_FALSE(r.new_segment) << i;
    T_world_last = r.T_world_camera;
  }
  const int keyframes_before = feed.tracker().num_keyframes();
  for (size_t i = 60; i < 65; ++i) {
    const TrackingResult r = feed.Pose(gt[i].T_world_camera);
    EXPECT_EQ(r.state, TrackingState::kLost) << i;
    EXPECT_FALSE(r.is_keyframe) << i;
    EXPECT_FALSE(r.new_segment) << i;
    EXPECT_TRUE(r.T_world_camera.isApprox(T_world_last)) << i;
  }
  const TrackingResult start = feed.Pose(gt[65].T_world_camera);
  ASSERT_EQ(start.state, TrackingState::kReinitialised);
  EXPECT_EQ(TrackingStateName(start.state), "reinitialised");
  EXPECT_TRUE(start.new_segment);
  EXPECT_TRUE(start.is_keyframe);
  ASSERT_NE(start.keyframe_features, nullptr);
  EXPECT_GE(start.keyframe_features->NumWithDepth(),
            2 * static_cast<size_t>(options.motion.min_inliers));
  EXPECT_TRUE(start.information.isZero());
  EXPECT_TRUE(start.T_world_camera.isApprox(T_world_last)) << "placed at the last known pose";
  EXPECT_EQ(feed.tracker().num_keyframes(), keyframes_before + 1);
  for (size_t i = 66; i < 90; ++i) {
    const TrackingResult r = feed.Pose(gt[i].T_world_camera);
    ASSERT_EQ(r.state, TrackingState::kTracking) << i;
    EXPECT_FALSE(r.new_segment) << i;
    const Eigen::Isometry3d truth = gt[65].T_world_camera.inverse() * gt[i].T_world_camera;
    const Eigen::Isometry3d estimate = start.T_world_camera.inverse() * r.T_world_camera;
    const Eigen::Isometry3d error = truth.inverse() * estimate;
    EXPECT_LT(error.translation().norm(), 0.01) << i;
    EXPECT_LT(odometry_test::AngleDeg(error), 0.5) << i;
  }
}

// A re-initialisation frame that is too poor (no keypoints with depth) stays lost and the next
// one is tried; frames without depth do not count towards the loss.
TEST(RgbdTrackerTest, PoorAndDepthlessFramesDoNotStartASegment) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera(320, 240);
  const synth::Renderer renderer = MakeRenderer(camera);
  const std::vector<StampedPose> gt = Circle(120);
  RgbdTrackerOptions options;
  options.T_world_first = gt.front().T_world_camera;
  options.reinitialise_after_lost = 4;
  Feeder feed(camera, renderer, options);
  for (size_t i = 0; i < 20; ++i) {
    ASSERT_EQ(feed.Pose(gt[i].T_world_camera).state, TrackingState::kTracking) << i;
  }
  // Lost with depth: 60, 61, 63, 64 (4); 62 has no depth and does not count.
  for (size_t i = 60; i < 65; ++i) {
    const TrackingResult r = feed.Pose(gt[i].T_world_camera, /*with_depth=*/i != 62);
    EXPECT_EQ(r.state, TrackingState::kLost) << i;
    EXPECT_FALSE(r.is_keyframe) << i;
  }
  // Past the threshold, but nothing to start from.
  for (int k = 0; k < 2; ++k) {
    const TrackingResult blank = feed.Blank();
    EXPECT_EQ(blank.state, TrackingState::kLost) << k;
    EXPECT_FALSE(blank.new_segment) << k;
    EXPECT_FALSE(blank.is_keyframe) << k;
  }
  // Past the threshold but without depth: no segment either.
  EXPECT_EQ(feed.Pose(gt[65].T_world_camera, /*with_depth=*/false).state, TrackingState::kLost);
  const TrackingResult start = feed.Pose(gt[66].T_world_camera);
  EXPECT_EQ(start.state, TrackingState::kReinitialised);
  EXPECT_TRUE(start.new_segment);
  EXPECT_TRUE(start.is_keyframe);
  const TrackingResult next = feed.Pose(gt[67].T_world_camera);
  EXPECT_EQ(next.state, TrackingState::kTracking);
  EXPECT_FALSE(next.new_segment);
}

TEST(RgbdTrackerTest, WithReinitialisationDisabledALostTrackerStaysLost) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera(320, 240);
  const synth::Renderer renderer = MakeRenderer(camera);
  const std::vector<StampedPose> gt = Circle(120);
  RgbdTrackerOptions options;
  options.T_world_first = gt.front().T_world_camera;
  options.reinitialise_after_lost = 0;
  Feeder feed(camera, renderer, options);
  for (size_t i = 0; i < 20; ++i) {
    ASSERT_EQ(feed.Pose(gt[i].T_world_camera).state, TrackingState::kTracking) << i;
  }
  for (size_t i = 60; i < 80; ++i) {
    const TrackingResult r = feed.Pose(gt[i].T_world_camera);
    EXPECT_EQ(r.state, TrackingState::kLost) << i;
    EXPECT_FALSE(r.is_keyframe) << i;
    EXPECT_FALSE(r.new_segment) << i;
  }
}

// Relocalisation is tried before re-initialisation, however long the loss: back at an old
// view after more than reinitialise_after_lost lost frames, the old map is found again.
TEST(RgbdTrackerTest, RelocalisationIsPreferredToANewSegment) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera(320, 240);
  const synth::Renderer renderer = MakeRenderer(camera);
  const std::vector<StampedPose> gt = Circle(120);
  RgbdTrackerOptions options;
  options.T_world_first = gt.front().T_world_camera;
  options.relocalisation_keyframes = 30;
  Feeder feed(camera, renderer, options);
  for (size_t i = 0; i <= 30; ++i) {
    ASSERT_EQ(feed.Pose(gt[i].T_world_camera).state, TrackingState::kTracking) << i;
  }
  for (int k = 0; k < options.reinitialise_after_lost + 3; ++k) {
    EXPECT_EQ(feed.Blank().state, TrackingState::kLost) << k;
  }
  const TrackingResult back = feed.Pose(gt[2].T_world_camera);
  EXPECT_EQ(back.state, TrackingState::kRelocalised);
  EXPECT_FALSE(back.new_segment);
  EXPECT_LT((gt[2].T_world_camera.inverse() * back.T_world_camera).translation().norm(), 0.03);
}

TEST(RgbdTrackerTest, RejectsBadOptionsAndInput) {
  RgbdTrackerOptions bad;
  EXPECT_EQ(CreateTracker(bad).status().code(), StatusCode::kInvalidArgument);  // no camera
  bad.camera = synth::DefaultSyntheticCamera(320, 240);
  // (min_inlier_fraction is the keyframe policy's now: keyframe_policy_test.)
  EXPECT_EQ(RgbdTracker::Create(bad, nullptr).status().code(), StatusCode::kInvalidArgument);
  bad.reinitialise_after_lost = -1;
  EXPECT_EQ(CreateTracker(bad).status().code(), StatusCode::kInvalidArgument);
  bad.reinitialise_after_lost = 0;  // disabled: valid
  EXPECT_TRUE(CreateTracker(bad).ok());
  RgbdTracker tracker = MakeTracker(synth::DefaultSyntheticCamera(320, 240));
  const cv::Mat grey(240, 320, CV_8UC1, cv::Scalar(0));
  EXPECT_EQ(tracker.Track(grey, Depth(cv::Mat(120, 160, CV_16UC1), 5000), 1).status().code(),
            StatusCode::kInvalidArgument);
  ASSERT_TRUE(tracker.Track(grey, Depth(cv::Mat(240, 320, CV_16UC1, cv::Scalar(0)), 5000), 5).ok());
  EXPECT_EQ(tracker.Track(grey, Depth(cv::Mat(240, 320, CV_16UC1, cv::Scalar(0)), 5000), 5)
                .status()
                .code(),
            StatusCode::kInvalidArgument);  // stamps must increase
}

struct DatasetRun {
  int frames = 0, lost = 0, keyframes = 0;
  double p50_ms = 0, mean_ms = 0;
  std::vector<StampedPose> estimate;
};

// Tracks every frame with depth of `dataset` (fails the test on an error).
DatasetRun RunDataset(const Dataset& dataset) {
  RgbdTracker tracker = MakeTracker(dataset.camera);
  DatasetRun run;
  std::vector<double> ms;
  for (const DatasetFrame& frame : dataset.frames) {
    if (!frame.depth_path) continue;
    ++run.frames;
    const cv::Mat bgr = cv::imread(frame.colour_path, cv::IMREAD_COLOR);
    const cv::Mat depth = cv::imread(*frame.depth_path, cv::IMREAD_UNCHANGED);
    EXPECT_FALSE(bgr.empty()) << frame.colour_path;
    EXPECT_EQ(depth.type(), CV_16UC1) << *frame.depth_path;
    if (bgr.empty() || depth.type() != CV_16UC1) return run;
    StatusOr<TrackingResult> r =
        tracker.Track(bgr, Depth(depth, dataset.depth_scale), frame.stamp_ns);
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    if (!r.ok()) return run;
    EXPECT_TRUE(r->T_world_camera.matrix().allFinite());
    run.lost += r->state == TrackingState::kLost ? 1 : 0;
    run.keyframes += r->is_keyframe ? 1 : 0;
    ms.push_back(r->timings.total_ms);
    run.estimate.push_back({frame.stamp_ns, r->T_world_camera});
  }
  if (!ms.empty()) {
    run.mean_ms = std::accumulate(ms.begin(), ms.end(), 0.0) / static_cast<double>(ms.size());
    std::nth_element(ms.begin(), ms.begin() + static_cast<long>(ms.size() / 2), ms.end());
    run.p50_ms = ms[ms.size() / 2];
  }
  return run;
}

TEST(RgbdTrackerTest, TumTeddyTracksEveryFrame) {
  const std::string shared = testing::SharedDataDir();
  if (shared.empty()) GTEST_SKIP() << "shared data dir absent (SEMMAP_SHARED_DATA_DIR)";
  StatusOr<Dataset> dataset = OpenDataset(shared + "/tum_fr3_teddy_200");
  if (!dataset.ok())
    GTEST_SKIP() << "tum_fr3_teddy_200 not available: " << dataset.status().ToString();
  ASSERT_FALSE(dataset->ground_truth.empty());
  const DatasetRun run = RunDataset(*dataset);
  StatusOr<AteResult> ate = ComputeAte(dataset->ground_truth, run.estimate);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  std::printf(
      "tum_fr3_teddy_200 (%d frames): ATE RMSE %.4f m, max %.4f m over %zu pairs, "
      "%d keyframes, %d lost, %.1f ms/frame p50, %.1f mean\n",
      run.frames, ate->stats.rmse, ate->stats.max, ate->pairs.size(), run.keyframes, run.lost,
      run.p50_ms, run.mean_ms);
  EXPECT_EQ(run.lost, 0);
  EXPECT_LT(ate->stats.rmse, 0.05);
}

// No ground truth: robustness only (every frame tracked on a real Kinect v1 sequence).
TEST(RgbdTrackerTest, KinectCafeTracksEveryFrame) {
  const std::string shared = testing::SharedDataDir();
  if (shared.empty()) GTEST_SKIP() << "shared data dir absent (SEMMAP_SHARED_DATA_DIR)";
  StatusOr<Dataset> dataset = OpenDataset(shared + "/kinect_cafe_391_nogt");
  if (!dataset.ok())
    GTEST_SKIP() << "kinect_cafe_391_nogt not available: " << dataset.status().ToString();
  const DatasetRun run = RunDataset(*dataset);
  Eigen::Vector3d end = Eigen::Vector3d::Zero();
  if (!run.estimate.empty()) end = run.estimate.back().T_world_camera.translation();
  std::printf(
      "kinect_cafe_391_nogt (%d frames): %d keyframes, %d lost, %.1f ms/frame p50, %.1f mean, "
      "end at (%.3f, %.3f, %.3f)\n",
      run.frames, run.keyframes, run.lost, run.p50_ms, run.mean_ms, end.x(), end.y(), end.z());
  EXPECT_EQ(run.lost, 0);
}

}  // namespace
}  // namespace semmap
