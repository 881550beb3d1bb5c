#include "server/slam/keyframe_selector.h"

#include <gtest/gtest.h>

#include <cmath>

namespace semmap {
namespace {

Eigen::Isometry3d Pose(double x, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  T.translation().x() = x;
  return T;
}

TEST(KeyframeSelectorTest, FirstFrameIsKeyframeThenThreshold) {
  KeyframeSelector selector({/*min_motion=*/0.1, /*rotation_weight=*/0.5});
  EXPECT_TRUE(selector.Decide(Pose(0, 0)));
  EXPECT_FALSE(selector.Decide(Pose(0.05, 0)));
  EXPECT_FALSE(selector.Decide(Pose(0.099, 0)));
  EXPECT_TRUE(selector.Decide(Pose(0.11, 0)));  // measured from the last keyframe
  EXPECT_FALSE(selector.Decide(Pose(0.2, 0)));
  EXPECT_TRUE(selector.Decide(Pose(0.22, 0)));
}

TEST(KeyframeSelectorTest, RotationCountsWithItsWeight) {
  KeyframeSelector selector({0.1, 0.5});
  EXPECT_TRUE(selector.Decide(Pose(0, 0)));
  EXPECT_FALSE(selector.Decide(Pose(0, 0.19)));  // 0.5 * 0.19 = 0.095
  EXPECT_TRUE(selector.Decide(Pose(0, 0.21)));   // 0.105
  EXPECT_NEAR(selector.MotionNorm(Pose(0.06, 0.16)), std::hypot(0.06, 0.08), 1e-12);
}

TEST(KeyframeSelectorTest, OptionsAreValidated) {
  EXPECT_TRUE(KeyframeSelectorOptions{}.Validate().ok());
  EXPECT_FALSE((KeyframeSelectorOptions{0, 0.5}).Validate().ok());
  EXPECT_FALSE((KeyframeSelectorOptions{0.1, -1}).Validate().ok());
  EXPECT_FALSE((KeyframeSelectorOptions{std::nan(""), 0.5}).Validate().ok());
}

}  // namespace
}  // namespace semmap
