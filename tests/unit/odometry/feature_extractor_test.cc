#include "core/odometry/feature_extractor.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

#include "core/odometry/internal/orb_keypoints.h"
#include "tests/testing/pinhole_camera.h"
#include "tests/unit/odometry/odometry_test_util.h"

namespace semmap {
namespace {

using odometry_test::Circle;
using odometry_test::Extract;
using odometry_test::MakeRenderer;
using odometry_test::Project;

FeatureExtractor MakeExtractor(const CameraCalibration& camera,
                               FeatureExtractorOptions options = {}) {
  StatusOr<FeatureExtractor> e = FeatureExtractor::Create(options, camera);
  EXPECT_TRUE(e.ok()) << e.status().ToString();
  return std::move(e).value();
}

TEST(FeatureExtractorTest, KeypointsSpreadOverTheGrid) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  const synth::Renderer renderer = MakeRenderer(camera);
  const FeatureExtractor extractor = MakeExtractor(camera);
  const FrameFeatures f = Extract(extractor, renderer.Render(Circle(8)[0].T_world_camera));
  ASSERT_EQ(f.descriptors.rows, static_cast<int>(f.size()));
  EXPECT_GE(f.size(), 900u);
  EXPECT_LE(f.size(), 1000u);
  std::vector<int> per_cell(48, 0);
  for (const cv::KeyPoint& k : f.keypoints) {
    const int cell = static_cast<int>(k.pt.y / 80) * 8 + static_cast<int>(k.pt.x / 80);
    ++per_cell[static_cast<size_t>(cell)];
  }
  const int occupied = static_cast<int>(
      std::count_if(per_cell.begin(), per_cell.end(), [](int n) { return n > 0; }));
  EXPECT_GE(occupied, 44) << "of 48 cells";
  // No cell hogs the budget: the equal share is 20, leftovers go to the strongest elsewhere.
  EXPECT_LE(*std::max_element(per_cell.begin(), per_cell.end()), 120);
  EXPECT_GT(f.NumWithDepth(), f.size() * 9 / 10);
}

TEST(FeatureExtractorTest, DepthAgreesWithTheRenderedGeometry) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  const synth::Renderer renderer = MakeRenderer(camera);
  const FeatureExtractor extractor = MakeExtractor(camera);
  const std::vector<StampedPose> poses = Circle(60);
  const Eigen::Isometry3d T_w_a = poses[0].T_world_camera, T_w_b = poses[3].T_world_camera;
  const synth::RenderedFrame a = renderer.Render(T_w_a), b = renderer.Render(T_w_b);
  const FrameFeatures f = Extract(extractor, a);
  // Each keypoint's 3D point, seen from another pose, must lie on the surface that view renders
  // there (an independent check of pixel, depth and unprojection conventions).
  int checked = 0, within_1cm = 0;
  std::vector<double> errors;
  for (size_t i = 0; i < f.size(); ++i) {
    if (!f.has_depth[i]) continue;
    const Eigen::Vector3d& p = f.points_camera[i];
    EXPECT_NEAR(Project(camera, p).x(), f.keypoints[i].pt.x, 1e-6);
    const Eigen::Vector3d q = T_w_b.inverse() * (T_w_a * p);
    const Eigen::Vector2d uv = Project(camera, q);
    const int u = static_cast<int>(std::lround(uv.x())), v = static_cast<int>(std::lround(uv.y()));
    if (q.z() <= 0 || u < 0 || v < 0 || u >= camera.width || v >= camera.height) continue;
    const uint16_t raw = b.depth.at<uint16_t>(v, u);
    if (raw == 0) continue;
    const double err = std::abs(raw / synth::kDepthScale - q.z());
    errors.push_back(err);
    ++checked;
    if (err < 0.01) ++within_1cm;
  }
  std::printf("DBG size %zu depth %zu checked %d\n", f.size(), f.NumWithDepth(), checked);
  ASSERT_GT(checked, 400);  // a sample for the statistics below (about half leave the view)
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.003);
  // Keypoints like corners sit on depth edges, where half a pixel changes the surface.
  EXPECT_GT(within_1cm, checked * 85 / 100) << within_1cm << " of " << checked;
}

TEST(FeatureExtractorTest, DepthOutsideTheRangeOrMissingGivesNoPoint) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera(320, 240);
  const synth::Renderer renderer = MakeRenderer(camera);
  const FeatureExtractor extractor = MakeExtractor(camera);
  synth::RenderedFrame frame = renderer.Render(Circle(8)[0].T_world_camera);
  // Left third: no depth; right third: 9 m (beyond 8 m).
  frame.depth.colRange(0, 100).setTo(0);
  frame.depth.colRange(220, 320).setTo(static_cast<uint16_t>(9.0 * synth::kDepthScale));
  const FrameFeatures f = Extract(extractor, frame);
  int middle = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    const float x = f.keypoints[i].pt.x;
    if (x < 99.5f || x > 219.5f) {
      EXPECT_FALSE(f.has_depth[i]) << x;
    }
    if (x > 101 && x < 218) middle += f.has_depth[i] ? 1 : 0;
  }
  EXPECT_GT(middle, 50);
  // Without a depth image, no keypoint has a point.
  StatusOr<FrameFeatures> no_depth = extractor.Extract(frame.bgr, cv::Mat(), 0);
  ASSERT_TRUE(no_depth.ok());
  EXPECT_EQ(no_depth->NumWithDepth(), 0u);
}

TEST(FeatureExtractorTest, DistortedCameraGivesUndistortedKeypoints) {
  const CameraCalibration pinhole = synth::DefaultSyntheticCamera(320, 240);
  CameraCalibration distorted = pinhole;
  distorted.distortion = {0.12, -0.05, 0.001, -0.001, 0.0};
  const synth::RenderedFrame frame = MakeRenderer(pinhole).Render(Circle(8)[1].T_world_camera);
  const FrameFeatures raw = Extract(MakeExtractor(pinhole), frame);
  const FrameFeatures und = Extract(MakeExtractor(distorted), frame);
  ASSERT_EQ(raw.size(), und.size());
  std::vector<cv::Point2f> in, expected;
  for (const cv::KeyPoint& k : raw.keypoints) in.push_back(k.pt);
  const cv::Matx33d K(pinhole.fx, 0, pinhole.cx, 0, pinhole.fy, pinhole.cy, 0, 0, 1);
  cv::undistortPoints(in, expected, K, cv::Mat(1, 5, CV_64F, distorted.distortion.data()),
                      cv::noArray(), K);
  double moved = 0;
  for (size_t i = 0; i < raw.size(); ++i) {
    EXPECT_NEAR(und.keypoints[i].pt.x, expected[i].x, 1e-3);
    EXPECT_NEAR(und.keypoints[i].pt.y, expected[i].y, 1e-3);
    moved =
        std::max(moved, static_cast<double>(cv::norm(und.keypoints[i].pt - raw.keypoints[i].pt)));
    // Depth comes from the raw pixel: the same availability either way.
    EXPECT_EQ(raw.has_depth[i], und.has_depth[i]);
  }
  EXPECT_GT(moved, 2.0);
}

TEST(FeatureExtractorTest, SiftAndAkazeAreSelectable) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera(320, 240);
  const synth::RenderedFrame frame = MakeRenderer(camera).Render(Circle(8)[2].T_world_camera);
  FeatureExtractorOptions sift;
  sift.type = FeatureType::kSift;
  sift.max_features = 300;
  const FrameFeatures s = Extract(MakeExtractor(camera, sift), frame);
  EXPECT_GT(s.size(), 100u);
  EXPECT_LE(s.size(), 300u);
  EXPECT_EQ(s.descriptors.type(), CV_32FC1);
  FeatureExtractorOptions akaze;
  akaze.type = FeatureType::kAkaze;
  akaze.max_features = 300;
  const FrameFeatures a = Extract(MakeExtractor(camera, akaze), frame);
  EXPECT_GT(a.size(), 100u);
  EXPECT_TRUE(a.binary_descriptors());
  EXPECT_EQ(a.descriptors.rows, static_cast<int>(a.size()));
}

TEST(FeatureExtractorTest, RejectsBadOptionsAndInput) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera(320, 240);
  FeatureExtractorOptions bad;
  bad.max_depth_m = 0.05;
  EXPECT_EQ(FeatureExtractor::Create(bad, camera).status().code(), StatusCode::kInvalidArgument);
  const FeatureExtractor extractor = MakeExtractor(camera);
  const cv::Mat wrong_size(100, 100, CV_8UC1, cv::Scalar(0));
  EXPECT_EQ(extractor.Extract(wrong_size, cv::Mat(), 0).status().code(),
            StatusCode::kInvalidArgument);
  const cv::Mat grey(240, 320, CV_8UC1, cv::Scalar(0));
  const cv::Mat float_depth(240, 320, CV_32FC1, cv::Scalar(1));
  EXPECT_EQ(extractor.Extract(grey, float_depth, 5000).status().code(),
            StatusCode::kInvalidArgument);
  // A blank image has no features, which is not an error.
  StatusOr<FrameFeatures> blank =
      extractor.Extract(grey, cv::Mat(240, 320, CV_16UC1, cv::Scalar(0)), 5000);
  ASSERT_TRUE(blank.ok());
  EXPECT_EQ(blank->size(), 0u);
}

TEST(BucketKeypointsTest, EqualSharesFirstThenStrongest) {
  std::vector<cv::KeyPoint> k;
  // 100 strong keypoints crowded in the top-left cell, 3 weak ones in the bottom-right.
  k.reserve(100);
  for (int i = 0; i < 100; ++i) {
    const int column = i % 10, row = i / 10;  // a 10 x 10 grid of points one pixel apart
    k.emplace_back(cv::Point2f(1.0f + static_cast<float>(column), 1.0f + static_cast<float>(row)),
                   7, -1, 100.0f + i);
  }
  for (int i = 0; i < 3; ++i) k.emplace_back(cv::Point2f(95.0f, 95.0f - i), 7, -1, 1.0f);
  const std::vector<cv::KeyPoint> out = BucketKeypoints(k, 100, 100, 2, 2, 20);
  ASSERT_EQ(out.size(), 20u);
  EXPECT_EQ(
      std::count_if(out.begin(), out.end(), [](const cv::KeyPoint& p) { return p.pt.x > 50; }), 3);
}

TEST(FillSparseCellsTest, WeakCornersOnlyFillCellsShortOfTheirShare) {
  // Top-left cell: 5 strong keypoints (its share); bottom-right: 1.
  std::vector<cv::KeyPoint> strong;
  strong.reserve(6);
  for (int i = 0; i < 5; ++i) strong.emplace_back(cv::Point2f(10.0f + 5 * i, 10.0f), 7, -1, 50);
  strong.emplace_back(cv::Point2f(80, 80), 7, -1, 50);
  std::vector<cv::KeyPoint> weak;
  weak.reserve(13);
  for (int i = 0; i < 6; ++i) weak.emplace_back(cv::Point2f(12.0f + 5 * i, 30.0f), 7, -1, 1);
  weak.emplace_back(cv::Point2f(81, 80), 7, -1, 9);  // the bottom-right corner found again
  for (int i = 0; i < 6; ++i) {
    weak.emplace_back(cv::Point2f(60.0f + 5 * i, 60.0f), 7, -1, static_cast<float>(2 + i));
  }
  FillSparseCells(&strong, weak, 100, 100, 2, 2, /*share=*/5);
  const auto in = [&](float x0, float y0) {
    return std::count_if(strong.begin(), strong.end(), [&](const cv::KeyPoint& k) {
      return k.pt.x >= x0 && k.pt.x < x0 + 50 && k.pt.y >= y0 && k.pt.y < y0 + 50;
    });
  };
  EXPECT_EQ(in(0, 0), 5);    // already full: no weak corner added
  EXPECT_EQ(in(50, 50), 5);  // 1 + the 4 strongest weak ones; the duplicate at (81, 80) not
  EXPECT_EQ(std::count_if(strong.begin(), strong.end(),
                          [](const cv::KeyPoint& k) { return k.pt.x == 81; }),
            0);
  EXPECT_EQ(in(50, 0) + in(0, 50), 0);  // empty cells with no corners stay empty
}

TEST(FeatureExtractorTest, FaintTextureStillGetsFeaturesWithTheWeakThreshold) {
  // A low-contrast random texture: few corners pass FAST 20, many pass 7.
  cv::Mat image(240, 320, CV_8UC1);
  cv::RNG rng(3);
  cv::Mat noise(60, 80, CV_8UC1);
  rng.fill(noise, cv::RNG::UNIFORM, 118, 138);
  cv::resize(noise, image, image.size(), 0, 0, cv::INTER_NEAREST);
  const CameraCalibration camera = testing::PinholeCamera(320, 240, 260);
  FeatureExtractorOptions strong_only;
  strong_only.orb_min_fast_threshold = 0;
  const FeatureExtractor a = MakeExtractor(camera, strong_only);
  const FeatureExtractor b = MakeExtractor(camera);
  auto fa = a.Extract(image, cv::Mat(), 0);
  auto fb = b.Extract(image, cv::Mat(), 0);
  ASSERT_TRUE(fa.ok() && fb.ok());
  EXPECT_GT(fb->size(), 2 * fa->size() + 100) << fa->size() << " vs " << fb->size();
  EXPECT_EQ(fb->descriptors.rows, static_cast<int>(fb->size()));
  FeatureExtractorOptions bad;
  bad.orb_min_fast_threshold = 30;
  EXPECT_EQ(FeatureExtractor::Create(bad, camera).status().code(), StatusCode::kInvalidArgument);
}

// Three bands: strong texture, fainter texture the main threshold still finds (its cells lose
// to the strong band in the level budgets), and texture only the weak threshold finds. The weak
// search runs only where the main one found too little: the fainter band's keypoints are the
// main threshold's corners (all but the few of cells where it found too few), the faintest band
// gets the weak threshold's.
TEST(FeatureExtractorTest, TheWeakThresholdSearchesOnlyWhereTheMainOneFoundTooLittle) {
  cv::RNG rng(5);
  cv::Mat image(240, 360, CV_8UC1);
  const std::pair<int, int> contrast[3] = {{0, 256}, {88, 168}, {122, 136}};
  for (int band = 0; band < 3; ++band) {
    cv::Mat blocks(30, 15, CV_8UC1);
    rng.fill(blocks, cv::RNG::UNIFORM, contrast[band].first, contrast[band].second);
    cv::resize(blocks, image.colRange(120 * band, 120 * (band + 1)), cv::Size(120, 240), 0, 0,
               cv::INTER_NEAREST);
  }
  const CameraCalibration camera = testing::PinholeCamera(360, 240, 260);
  FeatureExtractorOptions options;
  options.grid_cols = 9;
  options.max_features = 540;  // 10 per cell of the 9 x 6 grid
  StatusOr<FrameFeatures> features = MakeExtractor(camera, options).Extract(image, cv::Mat(), 0);
  ASSERT_TRUE(features.ok()) << features.status().ToString();

  // The main threshold's corners of every level.
  const internal::OrbPyramid pyramid = internal::BuildOrbPyramid(image, 4, 1.2);
  std::set<std::tuple<int, int, int>> main_corners;
  for (size_t l = 0; l < pyramid.levels.size(); ++l) {
    std::vector<cv::KeyPoint> found;
    cv::FAST(pyramid.levels[l], found, options.orb_fast_threshold, true);
    for (const cv::KeyPoint& k : found) {
      main_corners.emplace(static_cast<int>(l), static_cast<int>(k.pt.x), static_cast<int>(k.pt.y));
    }
  }
  int in_band[3] = {0, 0, 0}, main_in_band[3] = {0, 0, 0};
  for (const cv::KeyPoint& k : features->keypoints) {
    const int band = std::min(2, static_cast<int>(k.pt.x / 120));
    const double scale = pyramid.scales[static_cast<size_t>(k.octave)];
    ++in_band[band];
    main_in_band[band] += static_cast<int>(
        main_corners.count({k.octave, static_cast<int>(std::lround(k.pt.x / scale)),
                            static_cast<int>(std::lround(k.pt.y / scale))}));
  }
  std::printf("keypoints per band %d %d %d, of the main threshold %d %d %d\n", in_band[0],
              in_band[1], in_band[2], main_in_band[0], main_in_band[1], main_in_band[2]);
  // (Before the weak search was limited, a quarter of the fainter band's keypoints came from it:
  // 139, 100 of them the main threshold's.)
  EXPECT_GT(in_band[1], 60);
  EXPECT_GE(10 * main_in_band[1], 9 * in_band[1]);
  EXPECT_GE(in_band[2] - main_in_band[2], 10);
}

}  // namespace
}  // namespace semmap
