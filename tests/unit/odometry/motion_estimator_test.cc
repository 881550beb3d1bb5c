#include "core/odometry/motion_estimator.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "core/odometry/feature_extractor.h"
#include "core/odometry/feature_matcher.h"
#include "tests/unit/odometry/odometry_test_util.h"

namespace semmap {
namespace {

using odometry_test::AngleDeg;
using odometry_test::Circle;
using odometry_test::Extract;
using odometry_test::MakeRenderer;

// Correspondences from two rendered views: reference 3D points and current pixels.
struct Correspondences {
  std::vector<Eigen::Vector3d> points;
  std::vector<cv::Point2f> pixels;
  Eigen::Isometry3d T_ref_cur_true;
};

Correspondences FromRenderedViews(const CameraCalibration& camera, int from, int to) {
  const std::vector<StampedPose> poses = Circle(120);
  const synth::Renderer renderer = MakeRenderer(camera);
  StatusOr<FeatureExtractor> e = FeatureExtractor::Create({}, camera);
  EXPECT_TRUE(e.ok());
  const FrameFeatures ref =
      Extract(*e, renderer.Render(poses[static_cast<size_t>(from)].T_world_camera));
  const FrameFeatures cur =
      Extract(*e, renderer.Render(poses[static_cast<size_t>(to)].T_world_camera));
  StatusOr<std::vector<cv::DMatch>> matches =
      MatchDescriptors(ref.descriptors, cur.descriptors, {});
  EXPECT_TRUE(matches.ok());
  Correspondences c;
  for (const cv::DMatch& m : *matches) {
    if (!ref.has_depth[static_cast<size_t>(m.queryIdx)]) continue;
    c.points.push_back(ref.points_camera[static_cast<size_t>(m.queryIdx)]);
    c.pixels.push_back(cur.keypoints[static_cast<size_t>(m.trainIdx)].pt);
  }
  c.T_ref_cur_true = poses[static_cast<size_t>(from)].T_world_camera.inverse() *
                     poses[static_cast<size_t>(to)].T_world_camera;
  return c;
}

void ExpectClose(const Eigen::Isometry3d& estimated, const Eigen::Isometry3d& truth) {
  const Eigen::Isometry3d error = truth.inverse() * estimated;
  EXPECT_LT(error.translation().norm(), 0.01) << error.translation().transpose();
  EXPECT_LT(AngleDeg(error), 0.5);
}

TEST(MotionEstimatorTest, RecoversTheRelativePoseOfTwoRenderedViews) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  const Correspondences c = FromRenderedViews(camera, 20, 24);
  ASSERT_GT(c.points.size(), 100u);
  StatusOr<MotionEstimate> m = EstimateMotion(c.points, c.pixels, camera, {});
  ASSERT_TRUE(m.ok()) << m.status().ToString();
  ExpectClose(m->T_reference_current, c.T_ref_cur_true);
  EXPECT_GT(m->inliers.size(), c.points.size() * 8 / 10);
  EXPECT_LT(m->rms_reprojection_px, 1.5);
  // Information: symmetric positive definite, the covariance its inverse.
  EXPECT_TRUE(m->information.isApprox(m->information.transpose(), 1e-9));
  EXPECT_GT(m->information.ldlt().vectorD().minCoeff(), 0.0);
  EXPECT_TRUE(
      (m->covariance * m->information).isApprox(Eigen::Matrix<double, 6, 6>::Identity(), 1e-6));
}

TEST(MotionEstimatorTest, SurvivesThirtyPercentOutliers) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  Correspondences c = FromRenderedViews(camera, 40, 44);
  ASSERT_GT(c.points.size(), 100u);
  // Replace 30% of the pixels by random ones (wrong matches).
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> ux(0, 639), uy(0, 479);
  std::vector<bool> is_outlier(c.points.size(), false);
  for (size_t i = 0; i < c.points.size(); i += 10) {
    for (size_t k = i; k < std::min(i + 3, c.points.size()); ++k) {
      c.pixels[k] = cv::Point2f(ux(rng), uy(rng));
      is_outlier[k] = true;
    }
  }
  StatusOr<MotionEstimate> m = EstimateMotion(c.points, c.pixels, camera, {});
  ASSERT_TRUE(m.ok()) << m.status().ToString();
  ExpectClose(m->T_reference_current, c.T_ref_cur_true);
  int outliers_kept = 0;
  for (int i : m->inliers) outliers_kept += is_outlier[static_cast<size_t>(i)] ? 1 : 0;
  EXPECT_LT(outliers_kept, 5);
}

TEST(MotionEstimatorTest, ExactSyntheticCorrespondencesWithEpnp) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  Eigen::Isometry3d T_ref_cur = Eigen::Isometry3d::Identity();
  T_ref_cur.linear() =
      Eigen::AngleAxisd(0.1, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  T_ref_cur.translation() = Eigen::Vector3d(0.1, -0.05, 0.08);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> xy(-1.5, 1.5), z(1.0, 5.0);
  std::normal_distribution<float> noise(0.0f, 0.5f);
  std::vector<Eigen::Vector3d> points;
  std::vector<cv::Point2f> pixels;
  while (points.size() < 200) {
    const Eigen::Vector3d X(xy(rng), xy(rng), z(rng));
    const Eigen::Vector3d p = T_ref_cur.inverse() * X;
    const Eigen::Vector2d uv = odometry_test::Project(camera, p);
    if (p.z() < 0.5 || uv.x() < 0 || uv.y() < 0 || uv.x() > 639 || uv.y() > 479) continue;
    points.push_back(X);
    pixels.emplace_back(static_cast<float>(uv.x()) + noise(rng),
                        static_cast<float>(uv.y()) + noise(rng));
  }
  MotionEstimatorOptions options;
  options.method = PnpMethod::kEpnp;
  StatusOr<MotionEstimate> m = EstimateMotion(points, pixels, camera, options);
  ASSERT_TRUE(m.ok()) << m.status().ToString();
  ExpectClose(m->T_reference_current, T_ref_cur);
  EXPECT_GE(m->inliers.size(), 195u);
}

TEST(MotionEstimatorTest, TooFewMatchesIsAnErrorNotACrash) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  std::vector<Eigen::Vector3d> points(10, Eigen::Vector3d(0, 0, 2));
  std::vector<cv::Point2f> pixels(10, cv::Point2f(320, 240));
  StatusOr<MotionEstimate> m = EstimateMotion(points, pixels, camera, {});
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(m.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(m.status().message(), "too few matches (10 < 20)");
  // Enough matches but degenerate (all the same point): no pose, still no crash.
  points.assign(30, Eigen::Vector3d(0, 0, 2));
  pixels.assign(30, cv::Point2f(320, 240));
  StatusOr<MotionEstimate> degenerate = EstimateMotion(points, pixels, camera, {});
  if (degenerate.ok()) {
    EXPECT_TRUE(degenerate->T_reference_current.matrix().allFinite());
  }
  EXPECT_EQ(EstimateMotion(points, std::vector<cv::Point2f>(3), camera, {}).status().code(),
            StatusCode::kInvalidArgument);
  MotionEstimatorOptions bad;
  bad.ransac_threshold_px = -1;
  EXPECT_EQ(EstimateMotion(points, pixels, camera, bad).status().code(),
            StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
