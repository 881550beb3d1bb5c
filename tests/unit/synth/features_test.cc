// The synthetic frames are made for feature-based SLAM and recognition: many ORB keypoints in
// every view, and descriptors that match the same wall seen from elsewhere but not other walls.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/trajectory.h"
#include "tests/unit/synth/synth_test_util.h"

namespace semmap::synth {
namespace {

using Eigen::Vector3d;
using test::Camera640;
using test::DefaultScene;

struct Features {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  RenderedFrame frame;
};

class FeaturesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    StatusOr<Renderer> r = Renderer::Create(DefaultScene(), Camera640());
    ASSERT_TRUE(r.ok());
    renderer_.emplace(std::move(r).value());
  }

  Features Detect(const Eigen::Isometry3d& T) const {
    Features f;
    f.frame = renderer_->Render(T);
    orb_->detectAndCompute(f.frame.bgr, cv::noArray(), f.keypoints, f.descriptors);
    return f;
  }

  // Matches passing Lowe's ratio test, a -> b.
  static std::vector<cv::DMatch> Match(const Features& a, const Features& b) {
    cv::BFMatcher matcher(cv::NORM_HAMMING);
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(a.descriptors, b.descriptors, knn, 2);
    std::vector<cv::DMatch> good;
    for (const auto& m : knn) {
      if (m.size() == 2 && m[0].distance < 0.75f * m[1].distance) good.push_back(m[0]);
    }
    return good;
  }

  std::optional<Renderer> renderer_;
  cv::Ptr<cv::ORB> orb_ = cv::ORB::create(2000);
};

TEST_F(FeaturesTest, EveryTrajectoryViewHasManyKeypoints) {
  for (TrajectoryKind kind :
       {TrajectoryKind::kCircle, TrajectoryKind::kFigureEight, TrajectoryKind::kCorridorLoop,
        TrajectoryKind::kPureRotation, TrajectoryKind::kFastMotion}) {
    TrajectoryOptions options;
    options.frames = 8;
    StatusOr<std::vector<StampedPose>> poses = MakeTrajectory(kind, DefaultScene().room, options);
    ASSERT_TRUE(poses.ok());
    for (const StampedPose& p : *poses) {
      EXPECT_GT(Detect(p.T_world_camera).keypoints.size(), 500u) << TrajectoryKindName(kind);
    }
  }
}

TEST_F(FeaturesTest, AWallMatchesItselfFromElsewhereButNotAnotherWall) {
  const CameraCalibration c = Camera640();
  // The +x wall from two places 0.9 m apart, and the -x wall.
  const Eigen::Isometry3d T_a = LookingPose(Vector3d(0.0, 0.6, 1.5), 0.0, 0.05);
  const Eigen::Isometry3d T_b = LookingPose(Vector3d(0.6, -0.1, 1.3), 0.3, -0.05, 0.1);
  const Eigen::Isometry3d T_other = LookingPose(Vector3d(0.0, 0.6, 1.5), 3.14159265, 0.05);
  const Features a = Detect(T_a), b = Detect(T_b), other = Detect(T_other);

  // Same wall: many matches, and most are geometrically right (ground truth transfer).
  const std::vector<cv::DMatch> same = Match(a, b);
  int correct = 0;
  for (const cv::DMatch& m : same) {
    const cv::Point2f pa = a.keypoints[static_cast<size_t>(m.queryIdx)].pt;
    const double z = a.frame.depth.at<uint16_t>(cvRound(pa.y), cvRound(pa.x)) / kDepthScale;
    const std::optional<Eigen::Vector2d> pb =
        test::Project(c, T_b, test::Unproject(c, T_a, pa.x, pa.y, z));
    const cv::Point2f found = b.keypoints[static_cast<size_t>(m.trainIdx)].pt;
    if (pb && std::hypot(pb->x() - found.x, pb->y() - found.y) < 4.0) ++correct;
  }
  EXPECT_GT(correct, 200);
  EXPECT_GT(correct, 0.8 * same.size());

  // Another wall: hardly any matches survive the ratio test.
  const std::vector<cv::DMatch> cross = Match(a, other);
  EXPECT_LT(cross.size(), 0.1 * correct) << cross.size() << " vs " << correct;
}

}  // namespace
}  // namespace semmap::synth
