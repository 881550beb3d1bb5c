#include "server/odometry/rgbd_tracker.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "client/datasets/dataset.h"
#include "client/eval/ate.h"
#include "tests/testing/temp_dir.h"
#include "tests/unit/odometry/odometry_test_util.h"

namespace semmap {
namespace {

using odometry_test::Circle;
using odometry_test::MakeRenderer;

RgbdTracker MakeTracker(const CameraCalibration& camera, RgbdTrackerOptions options = {}) {
  options.camera = camera;
  StatusOr<RgbdTracker> t = RgbdTracker::Create(options);
  EXPECT_TRUE(t.ok()) << t.status().ToString();
  return std::move(t).value();
}

DecodedDepth Depth(const cv::Mat& raw, double scale) {
  DecodedDepth d;
  d.raw = raw;
  d.depth_scale = scale;
  return d;
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

TEST(RgbdTrackerTest, RejectsBadOptionsAndInput) {
  RgbdTrackerOptions bad;
  EXPECT_EQ(RgbdTracker::Create(bad).status().code(), StatusCode::kInvalidArgument);  // no camera
  bad.camera = synth::DefaultSyntheticCamera(320, 240);
  bad.min_inlier_fraction = 1.5;
  EXPECT_EQ(RgbdTracker::Create(bad).status().code(), StatusCode::kInvalidArgument);
  RgbdTracker tracker = MakeTracker(synth::DefaultSyntheticCamera(320, 240));
  const cv::Mat grey(240, 320, CV_8UC1, cv::Scalar(0));
  EXPECT_EQ(tracker.Track(grey, Depth(cv::Mat(), 5000), 1).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(tracker.Track(grey, Depth(cv::Mat(120, 160, CV_16UC1), 5000), 1).status().code(),
            StatusCode::kInvalidArgument);
  ASSERT_TRUE(tracker.Track(grey, Depth(cv::Mat(240, 320, CV_16UC1, cv::Scalar(0)), 5000), 5).ok());
  EXPECT_EQ(tracker.Track(grey, Depth(cv::Mat(240, 320, CV_16UC1, cv::Scalar(0)), 5000), 5)
                .status()
                .code(),
            StatusCode::kInvalidArgument);  // stamps must increase
}

TEST(RgbdTrackerTest, TumTeddyTracksEveryFrame) {
  const std::string shared = testing::SharedDataDir();
  if (shared.empty()) GTEST_SKIP() << "shared data dir absent (SEMMAP_SHARED_DATA_DIR)";
  StatusOr<Dataset> dataset = OpenDataset(shared + "/tum_fr3_teddy_200");
  if (!dataset.ok())
    GTEST_SKIP() << "tum_fr3_teddy_200 not available: " << dataset.status().ToString();
  ASSERT_FALSE(dataset->ground_truth.empty());
  RgbdTracker tracker = MakeTracker(dataset->camera);
  std::vector<StampedPose> estimate;
  int lost = 0, keyframes = 0, frames_with_depth = 0;
  double total_ms = 0;
  for (const DatasetFrame& frame : dataset->frames) {
    if (!frame.depth_path) continue;
    ++frames_with_depth;
    const cv::Mat bgr = cv::imread(frame.colour_path, cv::IMREAD_COLOR);
    const cv::Mat depth = cv::imread(*frame.depth_path, cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(bgr.empty()) << frame.colour_path;
    ASSERT_EQ(depth.type(), CV_16UC1) << *frame.depth_path;
    StatusOr<TrackingResult> r =
        tracker.Track(bgr, Depth(depth, dataset->depth_scale), frame.stamp_ns);
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    ASSERT_TRUE(r->T_world_camera.matrix().allFinite());
    lost += r->state == TrackingState::kLost ? 1 : 0;
    keyframes += r->is_keyframe ? 1 : 0;
    total_ms += r->timings.total_ms;
    estimate.push_back({frame.stamp_ns, r->T_world_camera});
  }
  StatusOr<AteResult> ate = ComputeAte(dataset->ground_truth, estimate);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  std::printf(
      "tum_fr3_teddy_200 (%d frames): ATE RMSE %.4f m, max %.4f m over %zu pairs, "
      "%d keyframes, %d lost, %.1f ms/frame mean\n",
      frames_with_depth, ate->stats.rmse, ate->stats.max, ate->pairs.size(), keyframes, lost,
      total_ms / frames_with_depth);
  EXPECT_EQ(lost, 0);
  EXPECT_LT(ate->stats.rmse, 0.05);
}

}  // namespace
}  // namespace semmap
