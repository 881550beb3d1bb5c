#include "server/odometry/feature_matcher.h"

#include <gtest/gtest.h>

#include <optional>
#include <vector>

#include "server/odometry/feature_extractor.h"
#include "tests/unit/odometry/odometry_test_util.h"

namespace semmap {
namespace {

using odometry_test::Circle;
using odometry_test::Extract;
using odometry_test::MakeRenderer;
using odometry_test::Project;

class FeatureMatcherTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::vector<StampedPose> poses = Circle(120);
    T_w_a_ = poses[10].T_world_camera;
    T_w_b_ = poses[13].T_world_camera;  // about 14 cm and 9 degrees apart
    const synth::Renderer renderer = MakeRenderer(camera_);
    StatusOr<FeatureExtractor> e = FeatureExtractor::Create({}, camera_);
    ASSERT_TRUE(e.ok());
    a_ = Extract(*e, renderer.Render(T_w_a_));
    b_ = Extract(*e, renderer.Render(T_w_b_));
  }

  // Where keypoint i of view a appears in view b (ground truth), when it has depth.
  std::optional<cv::Point2f> TrueProjection(size_t i) const {
    if (!a_.has_depth[i]) return std::nullopt;
    const Eigen::Vector3d q = T_w_b_.inverse() * (T_w_a_ * a_.points_camera[i]);
    if (q.z() <= 0) return std::nullopt;
    const Eigen::Vector2d uv = Project(camera_, q);
    return cv::Point2f(static_cast<float>(uv.x()), static_cast<float>(uv.y()));
  }

  // Counts matches whose b keypoint lies within 3 px of the true projection.
  std::pair<int, int> CorrectOfChecked(const std::vector<cv::DMatch>& matches) const {
    int correct = 0, checked = 0;
    for (const cv::DMatch& m : matches) {
      const std::optional<cv::Point2f> p = TrueProjection(static_cast<size_t>(m.queryIdx));
      if (!p) continue;
      ++checked;
      if (cv::norm(b_.keypoints[static_cast<size_t>(m.trainIdx)].pt - *p) < 3.0) ++correct;
    }
    return {correct, checked};
  }

  CameraCalibration camera_ = synth::DefaultSyntheticCamera();
  Eigen::Isometry3d T_w_a_, T_w_b_;
  FrameFeatures a_, b_;
};

TEST_F(FeatureMatcherTest, FullMatchingFindsTrueCorrespondences) {
  StatusOr<std::vector<cv::DMatch>> matches = MatchDescriptors(a_.descriptors, b_.descriptors, {});
  ASSERT_TRUE(matches.ok()) << matches.status().ToString();
  const auto [correct, checked] = CorrectOfChecked(*matches);
  EXPECT_GT(checked, 250);
  EXPECT_GT(correct, checked * 9 / 10) << correct << " of " << checked;
  // Mutual check: no train keypoint is used twice.
  std::vector<int> used(b_.size(), 0);
  for (const cv::DMatch& m : *matches) EXPECT_EQ(used[static_cast<size_t>(m.trainIdx)]++, 0);
}

TEST_F(FeatureMatcherTest, GuidedMatchingAroundTruePredictionsIsAtLeastAsGood) {
  std::vector<std::optional<cv::Point2f>> predicted(a_.size());
  for (size_t i = 0; i < a_.size(); ++i) predicted[i] = TrueProjection(i);
  StatusOr<std::vector<cv::DMatch>> guided =
      MatchGuided(a_.descriptors, predicted, b_.descriptors, b_.keypoints, {});
  ASSERT_TRUE(guided.ok()) << guided.status().ToString();
  StatusOr<std::vector<cv::DMatch>> full = MatchDescriptors(a_.descriptors, b_.descriptors, {});
  ASSERT_TRUE(full.ok());
  const auto [correct, checked] = CorrectOfChecked(*guided);
  EXPECT_GE(static_cast<double>(guided->size()), 0.9 * static_cast<double>(full->size()));
  EXPECT_GT(correct, checked * 95 / 100) << correct << " of " << checked;
  // Without predictions nothing matches.
  std::vector<std::optional<cv::Point2f>> none(a_.size());
  StatusOr<std::vector<cv::DMatch>> empty =
      MatchGuided(a_.descriptors, none, b_.descriptors, b_.keypoints, {});
  ASSERT_TRUE(empty.ok());
  EXPECT_TRUE(empty->empty());
}

TEST(FeatureMatcherInputTest, RejectsMismatchedDescriptorsAndAcceptsEmpty) {
  const cv::Mat binary(10, 32, CV_8UC1, cv::Scalar(1));
  const cv::Mat floats(10, 32, CV_32FC1, cv::Scalar(1));
  EXPECT_EQ(MatchDescriptors(binary, floats, {}).status().code(), StatusCode::kInvalidArgument);
  StatusOr<std::vector<cv::DMatch>> none = MatchDescriptors(cv::Mat(), binary, {});
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
  std::vector<std::optional<cv::Point2f>> two(2);
  EXPECT_EQ(MatchGuided(binary, two, binary, std::vector<cv::KeyPoint>(10), {}).status().code(),
            StatusCode::kInvalidArgument);
  FeatureMatcherOptions bad;
  bad.ratio = 1.5;
  EXPECT_FALSE(bad.Validate().ok());
}

TEST(FeatureMatcherInputTest, FloatDescriptorsMatchByL2) {
  cv::Mat a(3, 4, CV_32FC1), b(3, 4, CV_32FC1);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) {
      a.at<float>(i, j) = static_cast<float>(10 * i + j);
      b.at<float>(2 - i, j) = static_cast<float>(10 * i + j) + 0.1f;
    }
  }
  StatusOr<std::vector<cv::DMatch>> m = MatchDescriptors(a, b, {});
  ASSERT_TRUE(m.ok());
  ASSERT_EQ(m->size(), 3u);
  for (const cv::DMatch& d : *m) EXPECT_EQ(d.trainIdx, 2 - d.queryIdx);
}

}  // namespace
}  // namespace semmap
