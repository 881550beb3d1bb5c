#include "common/pose.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace semmap {
namespace {

TEST(PoseTest, RoundTripAndCanonicalSign) {
  PoseTq in;
  in.t = {1, 2, 3};
  in.q = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(0, 1, 1).normalized()));
  in.q.coeffs() *= -1;  // same rotation, negative w
  const PoseTq out = ToPoseTq(ToIsometry(in));
  EXPECT_TRUE(out.t.isApprox(in.t));
  EXPECT_GE(out.q.w(), 0);
  EXPECT_TRUE(out.q.toRotationMatrix().isApprox(in.q.toRotationMatrix(), 1e-12));
}

TEST(PoseTest, ValidationRejectsDegenerate) {
  PoseTq p;
  EXPECT_TRUE(ValidatePoseTq(p).ok());
  p.q = Eigen::Quaterniond(0, 0, 0, 0);
  EXPECT_EQ(ValidatePoseTq(p).code(), StatusCode::kInvalidArgument);
  p.q = Eigen::Quaterniond::Identity();
  p.t.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(ValidatePoseTq(p).code(), StatusCode::kInvalidArgument);
}

// UTM coordinates are places; a finite but absurd position is not.
TEST(PoseTest, PositionsAreBoundedToEarthScale) {
  PoseTq p;
  p.t = Eigen::Vector3d(690'000.0, 5'335'000.0, 500.0);  // UTM 32N, Munich
  EXPECT_TRUE(ValidatePoseTq(p).ok());
  p.t = Eigen::Vector3d(0, -kMaxPositionM, kMaxPositionM);
  EXPECT_TRUE(ValidatePoseTq(p).ok());
  p.t.z() = 1.0000001e7;
  const Status far = ValidatePoseTq(p);
  EXPECT_EQ(far.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(far.message().find("beyond 1e7 m"), std::string::npos) << far.message();
  p.t = Eigen::Vector3d(-3e300, 0, 0);
  EXPECT_EQ(ValidatePoseTq(p).code(), StatusCode::kInvalidArgument);
}

TEST(PoseTest, RotationAngleAndInterpolation) {
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d b = Eigen::Isometry3d::Identity();
  b.linear() = Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  b.translation() = Eigen::Vector3d(2, 0, 0);
  EXPECT_NEAR(RotationAngle(b), 1.0, 1e-12);
  const Eigen::Isometry3d mid = InterpolatePose(a, b, 0.5);
  EXPECT_NEAR(RotationAngle(mid), 0.5, 1e-12);
  EXPECT_NEAR(mid.translation().x(), 1.0, 1e-12);
}

}  // namespace
}  // namespace semmap
