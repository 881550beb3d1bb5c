#include "core/slam/keyframe_policy.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace semmap {
namespace {

Eigen::Isometry3d Pose(double x, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation().x() = x;
  return T;
}

KeyframeCandidate Known(const Eigen::Isometry3d& T) {
  KeyframeCandidate c;
  c.evidence = KeyframeEvidence::kKnownPose;
  c.T_world_camera = T;
  return c;
}

KeyframeCandidate Tracked(const Eigen::Isometry3d& T, int inliers, bool has_depth = true) {
  KeyframeCandidate c;
  c.evidence = KeyframeEvidence::kTracked;
  c.T_world_camera = T;
  c.num_inliers = inliers;
  c.has_depth = has_depth;
  return c;
}

KeyframeCandidate Start(const Eigen::Isometry3d& T) {
  KeyframeCandidate c;
  c.evidence = KeyframeEvidence::kSegmentStart;
  c.T_world_camera = T;
  return c;
}

KeyframePolicyOptions Options(double min_motion, double rotation_weight) {
  KeyframePolicyOptions o;
  o.min_motion = min_motion;
  o.rotation_weight = rotation_weight;
  return o;
}

TEST(KeyframePolicyTest, FirstFrameIsKeyframeThenThreshold) {
  KeyframePolicy policy(Options(/*min_motion=*/0.1, /*rotation_weight=*/0.5));
  EXPECT_TRUE(policy.Decide(Known(Pose(0, 0))));
  EXPECT_FALSE(policy.Decide(Known(Pose(0.05, 0))));
  EXPECT_FALSE(policy.Decide(Known(Pose(0.099, 0))));
  EXPECT_TRUE(policy.Decide(Known(Pose(0.11, 0))));  // measured from the last keyframe
  EXPECT_FALSE(policy.Decide(Known(Pose(0.2, 0))));
  EXPECT_TRUE(policy.Decide(Known(Pose(0.22, 0))));
}

TEST(KeyframePolicyTest, RotationCountsWithItsWeight) {
  KeyframePolicy policy(Options(0.1, 0.5));
  EXPECT_TRUE(policy.Decide(Known(Pose(0, 0))));
  EXPECT_FALSE(policy.Decide(Known(Pose(0, 0.19))));  // 0.5 * 0.19 = 0.095
  EXPECT_TRUE(policy.Decide(Known(Pose(0, 0.21))));   // 0.105
  EXPECT_NEAR(policy.MotionNorm(Pose(0.06, 0.16)), std::hypot(0.06, 0.08), 1e-12);
}

TEST(KeyframePolicyTest, OptionsAreValidated) {
  EXPECT_TRUE(KeyframePolicyOptions{}.Validate().ok());
  EXPECT_FALSE(Options(0, 0.5).Validate().ok());
  EXPECT_FALSE(Options(0.1, -1).Validate().ok());
  EXPECT_FALSE(Options(std::nan(""), 0.5).Validate().ok());
  KeyframePolicyOptions fraction;
  fraction.min_inlier_fraction = 1.5;
  EXPECT_FALSE(fraction.Validate().ok());
  fraction.min_inlier_fraction = -0.1;
  EXPECT_FALSE(fraction.Validate().ok());
  fraction.min_inlier_fraction = 0.4;
  EXPECT_TRUE(fraction.Validate().ok());
}

TEST(KeyframePolicyTest, TrackedFramesBecomeKeyframesWhenTheirInliersFallAway) {
  KeyframePolicy policy(Options(0.1, 0.5));  // min_inlier_fraction 0.4
  EXPECT_TRUE(policy.Decide(Start(Pose(0, 0))));
  EXPECT_FALSE(policy.Decide(Tracked(Pose(0.01, 0), 300)));  // the reference count: 300
  EXPECT_FALSE(policy.Decide(Tracked(Pose(0.02, 0), 121)));  // 121 >= 0.4 * 300
  EXPECT_TRUE(policy.Decide(Tracked(Pose(0.03, 0), 119)));   // weak: the view left the reference
  // The count starts again from the first frame tracked against the new keyframe.
  EXPECT_FALSE(policy.Decide(Tracked(Pose(0.04, 0), 100)));
  EXPECT_FALSE(policy.Decide(Tracked(Pose(0.05, 0), 41)));
  EXPECT_TRUE(policy.Decide(Tracked(Pose(0.06, 0), 39)));
  // ... and the motion norm from the new keyframe (0.06).
  EXPECT_FALSE(policy.Decide(Tracked(Pose(0.15, 0), 500)));
  EXPECT_TRUE(policy.Decide(Tracked(Pose(0.17, 0), 500)));
}

TEST(KeyframePolicyTest, FramesWithoutDepthNeverBecomeKeyframesNorSetTheReference) {
  KeyframePolicy policy(Options(0.1, 0.5));
  EXPECT_TRUE(policy.Decide(Start(Pose(0, 0))));
  EXPECT_FALSE(policy.Decide(Tracked(Pose(0.5, 0), 10, /*has_depth=*/false)));  // far, weak
  KeyframeCandidate relocalised = Tracked(Pose(0.5, 0), 10, /*has_depth=*/false);
  relocalised.evidence = KeyframeEvidence::kRelocalised;
  EXPECT_FALSE(policy.Decide(relocalised));
  // The first frame with depth sets the reference count, the motion is still measured from 0.
  EXPECT_FALSE(policy.Decide(Tracked(Pose(0.05, 0), 20)));
  EXPECT_FALSE(policy.Decide(Tracked(Pose(0.06, 0), 9)));
  EXPECT_TRUE(policy.Decide(Tracked(Pose(0.11, 0), 20)));
}

TEST(KeyframePolicyTest, RelocalisedFramesWithDepthAndSegmentStartsAreKeyframes) {
  KeyframePolicy policy(Options(0.1, 0.5));
  EXPECT_TRUE(policy.Decide(Start(Pose(0, 0))));
  KeyframeCandidate relocalised = Tracked(Pose(0.01, 0), 200);
  relocalised.evidence = KeyframeEvidence::kRelocalised;
  EXPECT_TRUE(policy.Decide(relocalised));
  EXPECT_TRUE(policy.Decide(Start(Pose(0.02, 0))));
  ASSERT_TRUE(policy.last_keyframe_pose().has_value());
  EXPECT_NEAR(policy.last_keyframe_pose()->translation().x(), 0.02, 1e-12);
}

TEST(KeyframePolicyTest, CorrectionsMoveTheReferenceWithTheMap) {
  KeyframePolicy policy(Options(0.1, 0.5));
  EXPECT_TRUE(policy.Decide(Known(Pose(0, 0))));
  // The map moved by +1 m in x: the same camera now sits at 1.05, 5 cm from the keyframe.
  policy.ApplyCorrection(Pose(1.0, 0));
  EXPECT_FALSE(policy.Decide(Known(Pose(1.05, 0))));
  EXPECT_TRUE(policy.Decide(Known(Pose(1.11, 0))));
}

// A revisit: the map already holds keyframes along the way (another session's, at x = 1.0,
// 1.1, ...). Frames near one of them make none by motion (weak inliers still make one); past
// the mapped ones the rule is a first visit's again.
TEST(KeyframePolicyTest, ViewsTheMapAlreadyHoldsMakeNoKeyframe) {
  const KeyframePolicyOptions on = Options(0.1, 0.5);  // skip_mapped_views by default
  ASSERT_TRUE(on.skip_mapped_views);
  KeyframePolicy policy(on);
  std::vector<Eigen::Isometry3d> mapped;
  for (int i = 0; i <= 5; ++i) mapped.push_back(Pose(1.0 + 0.1 * i, 0));
  const auto revisit = [&](double x, int inliers) {
    KeyframeCandidate c = Tracked(Pose(x, 0), inliers);
    c.mapped_keyframes = &mapped;
    return c;
  };
  EXPECT_TRUE(policy.Decide(Start(Pose(0.97, 0))));
  EXPECT_FALSE(policy.Decide(revisit(0.98, 300)));
  for (double x = 1.1; x < 1.5; x += 0.05) {
    EXPECT_FALSE(policy.Decide(revisit(x, 300))) << x;  // moved on, but mapped
  }
  EXPECT_TRUE(policy.Decide(revisit(1.5, 50)));     // weak: a keyframe even where mapped
  EXPECT_FALSE(policy.Decide(revisit(1.55, 300)));  // 0.05 from 1.5 (the new reference)
  EXPECT_TRUE(policy.Decide(revisit(1.66, 300)));   // beyond the last mapped keyframe (1.5)
  EXPECT_FALSE(policy.Decide(revisit(1.7, 300)));
  EXPECT_TRUE(policy.Decide(revisit(1.77, 300)));  // 0.11 from 1.66, 0.27 from 1.5

  // Turned away from the mapped view: not the same view.
  KeyframePolicy turning(on);
  EXPECT_TRUE(turning.Decide(Start(Pose(1.0, 0))));
  KeyframeCandidate turned = Tracked(Pose(1.1, 0.5), 300);
  turned.mapped_keyframes = &mapped;
  EXPECT_TRUE(turning.Decide(turned));

  // Off: a first visit's rule everywhere.
  KeyframePolicyOptions off = on;
  off.skip_mapped_views = false;
  KeyframePolicy adding(off);
  EXPECT_TRUE(adding.Decide(Start(Pose(0.97, 0))));
  EXPECT_TRUE(adding.Decide(revisit(1.1, 300)));
}

// The reference keyframe is among the mapped ones too (the back end's refined copy, 2 mm off):
// it does not make the frames around it count as mapped views.
TEST(KeyframePolicyTest, TheReferenceItselfDoesNotCountAsMapped) {
  KeyframePolicy policy(Options(0.1, 0.5));
  const std::vector<Eigen::Isometry3d> mapped = {Pose(0.002, 0)};
  EXPECT_TRUE(policy.Decide(Start(Pose(0, 0))));
  KeyframeCandidate c = Tracked(Pose(0.05, 0), 300);
  c.mapped_keyframes = &mapped;
  EXPECT_FALSE(policy.Decide(c));
  c = Tracked(Pose(0.101, 0), 300);  // moved 0.101; the refined copy is 0.099 away
  c.mapped_keyframes = &mapped;
  EXPECT_TRUE(policy.Decide(c));
}

// MONO: the learned VO's predicted motion is judged by the motion norm alone (no inliers, and
// predicted depth means every frame has depth).
TEST(KeyframePolicyTest, PredictedMotionIsJudgedByTheMotionNormAlone) {
  KeyframePolicy policy(Options(0.1, 0.5));
  ASSERT_TRUE(policy.Decide(Start(Pose(0, 0))));
  KeyframeCandidate c;
  c.evidence = KeyframeEvidence::kPredicted;
  c.num_inliers = 0;
  c.T_world_camera = Pose(0.05, 0);
  EXPECT_FALSE(policy.Decide(c));
  c.T_world_camera = Pose(0.0, 0.25);  // 0.125 m-equivalent of turning
  EXPECT_TRUE(policy.Decide(c));
  c.T_world_camera = Pose(0.08, 0.25);
  EXPECT_FALSE(policy.Decide(c));  // measured from the new keyframe
}

}  // namespace
}  // namespace semmap
