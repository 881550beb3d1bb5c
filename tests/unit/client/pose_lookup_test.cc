#include "client/datasets/pose_lookup.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "common/pose.h"
#include "tests/testing/units.h"

namespace semmap {
namespace {

constexpr int64_t kT0 = 1'000'000'000'000LL;  // an arbitrary epoch

StampedPose At(int64_t stamp_ns, double yaw, const Eigen::Vector3d& t) {
  StampedPose p;
  p.stamp_ns = stamp_ns;
  p.T_world_camera.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  p.T_world_camera.translation() = t;
  return p;
}

double Yaw(const Eigen::Isometry3d& T) { return std::atan2(T(1, 0), T(0, 0)); }

// Poses at 0, 10 ms, 20 ms, then a 300 ms gap, then 320 ms.
PoseLookup MakeLookup() {
  return PoseLookup({At(kT0, 0.0, {0, 0, 0}), At(kT0 + 10 * kMs, 0.2, {1, 0, 0}),
                     At(kT0 + 20 * kMs, 0.4, {1, 2, 0}), At(kT0 + 320 * kMs, 0.5, {9, 9, 9})});
}

TEST(PoseLookupTest, ExactStampGivesThatPose) {
  const PoseLookup lookup = MakeLookup();
  std::optional<Eigen::Isometry3d> T = lookup.At(kT0 + 10 * kMs);
  ASSERT_TRUE(T);
  EXPECT_TRUE(T->translation().isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_NEAR(Yaw(*T), 0.2, 1e-12);
  // Also exact at an end of a long gap and at the last pose.
  ASSERT_TRUE(lookup.At(kT0 + 320 * kMs));
  EXPECT_TRUE(lookup.At(kT0 + 320 * kMs)->translation().isApprox(Eigen::Vector3d(9, 9, 9)));
}

TEST(PoseLookupTest, InterpolatesLinearlyAndBySlerp) {
  const PoseLookup lookup = MakeLookup();
  std::optional<Eigen::Isometry3d> T = lookup.At(kT0 + 2500 * 1000);  // 2.5 ms: alpha 0.25
  ASSERT_TRUE(T);
  EXPECT_NEAR((T->translation() - Eigen::Vector3d(0.25, 0, 0)).norm(), 0, 1e-12);
  EXPECT_NEAR(Yaw(*T), 0.05, 1e-12);
  T = lookup.At(kT0 + 15 * kMs);  // halfway between 10 and 20 ms
  ASSERT_TRUE(T);
  EXPECT_NEAR((T->translation() - Eigen::Vector3d(1, 1, 0)).norm(), 0, 1e-12);
  EXPECT_NEAR(Yaw(*T), 0.3, 1e-12);
}

TEST(PoseLookupTest, NoInterpolationAcrossALongGap) {
  const PoseLookup lookup = MakeLookup();
  EXPECT_FALSE(lookup.At(kT0 + 21 * kMs));
  EXPECT_FALSE(lookup.At(kT0 + 319 * kMs));
}

TEST(PoseLookupTest, GapLimitIsInclusive) {
  PoseLookupOptions options;
  options.max_interp_gap_ns = 10 * kMs;
  const PoseLookup lookup({At(kT0, 0, {0, 0, 0}), At(kT0 + 10 * kMs, 0, {1, 0, 0}),
                           At(kT0 + 20 * kMs + 1, 0, {2, 0, 0})},
                          options);
  EXPECT_TRUE(lookup.At(kT0 + 5 * kMs));
  EXPECT_FALSE(lookup.At(kT0 + 15 * kMs));
}

TEST(PoseLookupTest, NearestPoseOutsideTheSpanUpToTheLimit) {
  const PoseLookup lookup = MakeLookup();
  std::optional<Eigen::Isometry3d> T = lookup.At(kT0 - 140 * kMs);
  ASSERT_TRUE(T);
  EXPECT_TRUE(T->translation().isZero());
  ASSERT_TRUE(lookup.At(kT0 - 200 * kMs));  // inclusive
  EXPECT_FALSE(lookup.At(kT0 - 200 * kMs - 1));
  T = lookup.At(kT0 + 520 * kMs);
  ASSERT_TRUE(T);
  EXPECT_TRUE(T->translation().isApprox(Eigen::Vector3d(9, 9, 9)));
  EXPECT_FALSE(lookup.At(kT0 + 520 * kMs + 1));
}

TEST(PoseLookupTest, CustomExtrapolationLimit) {
  PoseLookupOptions options;
  options.max_extrapolation_ns = 0;
  const PoseLookup lookup({At(kT0, 0, {0, 0, 0}), At(kT0 + 10 * kMs, 0, {1, 0, 0})}, options);
  EXPECT_TRUE(lookup.At(kT0));
  EXPECT_FALSE(lookup.At(kT0 - 1));
  EXPECT_FALSE(lookup.At(kT0 + 10 * kMs + 1));
}

TEST(PoseLookupTest, SortsUnsortedInput) {
  const PoseLookup lookup({At(kT0 + 10 * kMs, 0, {1, 0, 0}), At(kT0, 0, {0, 0, 0})});
  EXPECT_EQ(lookup.poses().front().stamp_ns, kT0);
  std::optional<Eigen::Isometry3d> T = lookup.At(kT0 + 5 * kMs);
  ASSERT_TRUE(T);
  EXPECT_NEAR(T->translation().x(), 0.5, 1e-12);
}

TEST(PoseLookupTest, EmptyAndSinglePose) {
  EXPECT_FALSE(PoseLookup({}).At(kT0));
  const PoseLookup single({At(kT0, 0, {1, 2, 3})});
  ASSERT_TRUE(single.At(kT0 + 100 * kMs));
  EXPECT_TRUE(single.At(kT0 + 100 * kMs)->translation().isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_FALSE(single.At(kT0 + 300 * kMs));
}

// Found by fuzz_trajectory (UBSan): stamps at the ends of what a trajectory file may hold
// (+-9e9 s) are 1.8e19 ns apart, more than int64 holds; the signed differences overflowed.
TEST(PoseLookupTest, StampsFarApartDoNotOverflow) {
  constexpr int64_t kFar = 9'000'000'000'000'000'000LL;
  constexpr int64_t kMin = std::numeric_limits<int64_t>::min();
  constexpr int64_t kMax = std::numeric_limits<int64_t>::max();
  const std::vector<StampedPose> poses = {At(-kFar, 0, {0, 0, 0}), At(kFar, 0, {1, 0, 0})};
  const PoseLookup lookup(poses);
  EXPECT_FALSE(lookup.At(0));  // inside the span, across a gap far beyond the limit
  EXPECT_FALSE(lookup.At(kMin));
  EXPECT_FALSE(lookup.At(kMax));
  EXPECT_TRUE(lookup.At(kFar));

  PoseLookupOptions unlimited;
  unlimited.max_interp_gap_ns = kMax;
  unlimited.max_extrapolation_ns = kMax;
  const PoseLookup wide(poses, unlimited);
  EXPECT_FALSE(wide.At(0));  // a 1.8e19 ns gap is beyond any int64 limit
  ASSERT_TRUE(wide.At(kMin));
  EXPECT_EQ(wide.At(kMin)->translation().x(), 0);
  ASSERT_TRUE(wide.At(kMax));
  EXPECT_EQ(wide.At(kMax)->translation().x(), 1);
  const PoseLookup half({At(-kFar / 2, 0, {0, 0, 0}), At(kFar / 2, 0, {1, 0, 0})}, unlimited);
  ASSERT_TRUE(half.At(0));
  EXPECT_NEAR(half.At(0)->translation().x(), 0.5, 1e-12);
}

}  // namespace
}  // namespace semmap
