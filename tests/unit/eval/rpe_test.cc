#include "client/eval/rpe.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "tests/testing/units.h"
#include "tests/unit/eval/eval_test_util.h"

namespace semmap {
namespace {

using eval_test::kT0;
using eval_test::MakePose;
using eval_test::Rot;

// Poses every `step_ms` for `count` poses, moving along x at `speed` m/s and turning about z at
// `turn_deg_per_s`.
std::vector<StampedPose> Drive(size_t count, int64_t step_ms, double speed, double turn_deg_per_s) {
  std::vector<StampedPose> out;
  for (size_t i = 0; i < count; ++i) {
    const double t = static_cast<double>(i) * static_cast<double>(step_ms) / 1000.0;
    out.push_back(MakePose(kT0 + static_cast<int64_t>(i) * step_ms * kMs, {speed * t, 0, 0},
                           Rot(turn_deg_per_s * t * kDeg, {0, 0, 1})));
  }
  return out;
}

TEST(RpeTest, ConstantVelocityDriftPerSecond) {
  // 10 s at 10 Hz; the estimate drives 10 % too fast: 0.1 m of error per second.
  const std::vector<StampedPose> gt = Drive(101, 100, 1.0, 0);
  const std::vector<StampedPose> est = Drive(101, 100, 1.1, 0);
  StatusOr<RpeResult> rpe = ComputeRpe(gt, est);
  ASSERT_TRUE(rpe.ok()) << rpe.status().ToString();
  // i = 0..89 pairs with i + 10; i = 90 would end on the last pose, which the script drops,
  // and later i find no partner 1 s ahead.
  EXPECT_EQ(rpe->pairs.size(), 90u);
  EXPECT_NEAR(rpe->translation_m.rmse, 0.1, 1e-12);
  EXPECT_NEAR(rpe->translation_m.min, 0.1, 1e-12);
  EXPECT_NEAR(rpe->translation_m.max, 0.1, 1e-12);
  EXPECT_NEAR(rpe->translation_m.std, 0, 1e-12);
  EXPECT_NEAR(rpe->rotation_deg.max, 0, 1e-5);
  EXPECT_EQ(rpe->pairs.front().est_stamp_ns[1] - rpe->pairs.front().est_stamp_ns[0], 1000 * kMs);
  EXPECT_NEAR(rpe->max_difference_s, 0.2, 1e-6);  // twice the 0.1 s ground-truth interval
}

TEST(RpeTest, ConstantVelocityDriftPerFrame) {
  const std::vector<StampedPose> gt = Drive(101, 100, 1.0, 0);
  const std::vector<StampedPose> est = Drive(101, 100, 1.1, 0);
  RpeOptions options;
  options.unit = RpeDeltaUnit::kFrames;
  options.delta = 1;
  StatusOr<RpeResult> rpe = ComputeRpe(gt, est, options);
  ASSERT_TRUE(rpe.ok()) << rpe.status().ToString();
  EXPECT_EQ(rpe->pairs.size(), 99u);  // (i, i+1) for i = 0..98; (99, 100) ends on the last pose
  EXPECT_NEAR(rpe->translation_m.mean, 0.01, 1e-12);
  EXPECT_NEAR(rpe->translation_m.max, 0.01, 1e-12);
}

TEST(RpeTest, ConstantTurnRateDrift) {
  // Turning 10 deg/s vs 11 deg/s in place: 1 deg of rotational error per second.
  const std::vector<StampedPose> gt = Drive(61, 50, 0.0, 10.0);
  const std::vector<StampedPose> est = Drive(61, 50, 0.0, 11.0);
  StatusOr<RpeResult> rpe = ComputeRpe(gt, est);
  ASSERT_TRUE(rpe.ok()) << rpe.status().ToString();
  EXPECT_EQ(rpe->pairs.size(), 40u);
  EXPECT_NEAR(rpe->rotation_deg.rmse, 1.0, 1e-9);
  EXPECT_NEAR(rpe->rotation_deg.median, 1.0, 1e-9);
  EXPECT_NEAR(rpe->rotation_deg.min, 1.0, 1e-9);
  EXPECT_NEAR(rpe->translation_m.max, 0, 1e-12);
}

TEST(RpeTest, ErrorIsTheScriptsEstimateTimesInverseGroundTruth) {
  // Ground truth moves 1 m along x per frame without turning; the estimate moves the same but
  // turns 90 deg per frame. With A = est_i^-1 est_j and B = gt_i^-1 gt_j the script evaluates
  // E = A B^-1: t_E = t_A - R_A t_B. (The paper's B^-1 A would give |t_A - t_B|.)
  std::vector<StampedPose> gt, est;
  for (int k = 0; k < 4; ++k) {
    gt.push_back(MakePose(kT0 + k * 100 * kMs, {1.0 * k, 0, 0}));
    est.push_back(MakePose(kT0 + k * 100 * kMs, {1.0 * k, 0, 0}, Rot(k * 90 * kDeg, {0, 0, 1})));
  }
  RpeOptions options;
  options.unit = RpeDeltaUnit::kFrames;
  StatusOr<RpeResult> rpe = ComputeRpe(gt, est, options);
  ASSERT_TRUE(rpe.ok()) << rpe.status().ToString();
  ASSERT_EQ(rpe->pairs.size(), 2u);
  // Pair (0,1): A = (Rz90, (1,0,0)), B = (I, (1,0,0)): t_E = (1,0,0) - (0,1,0), |t_E| = sqrt 2.
  EXPECT_NEAR(rpe->pairs[0].translation_error_m, std::sqrt(2.0), 1e-12);
  // Pair (1,2): A = (Rz90, (0,-1,0)): t_E = (0,-1,0) - (0,1,0), |t_E| = 2.
  EXPECT_NEAR(rpe->pairs[1].translation_error_m, 2.0, 1e-12);
  EXPECT_NEAR(rpe->pairs[0].rotation_error_deg, 90.0, 1e-9);
  EXPECT_NEAR(rpe->pairs[1].rotation_error_deg, 90.0, 1e-9);
}

TEST(RpeTest, PairsEndingOnTheLastPoseAreDropped) {
  const std::vector<StampedPose> gt = Drive(5, 100, 1.0, 0);
  RpeOptions options;
  options.unit = RpeDeltaUnit::kFrames;
  StatusOr<RpeResult> rpe = ComputeRpe(gt, gt, options);
  ASSERT_TRUE(rpe.ok()) << rpe.status().ToString();
  ASSERT_EQ(rpe->pairs.size(), 3u);  // (0,1) (1,2) (2,3), not (3,4)
  EXPECT_EQ(rpe->pairs.back().est_stamp_ns[1], gt[3].stamp_ns);
  EXPECT_NEAR(rpe->translation_m.max, 0, 1e-12);
}

TEST(RpeTest, StampsFarFromTheGroundTruthAreSkipped) {
  // Ground truth at 100 Hz over 3 s with a gap between 1.0 s and 1.5 s; estimate at 10 Hz.
  std::vector<StampedPose> gt;
  for (int k = 0; k <= 300; ++k) {
    if (k > 100 && k < 150) continue;
    gt.push_back(MakePose(kT0 + k * 10 * kMs, {0.01 * k, 0, 0}));
  }
  const std::vector<StampedPose> est = Drive(31, 100, 1.0, 0);
  RpeOptions options;
  options.unit = RpeDeltaUnit::kFrames;
  // Default: twice the median interval (0.02 s). Estimates at 1.1..1.4 s are 0.1..0.2 s from
  // the ground truth: the 5 pairs touching them go; 29 - 5 remain.
  StatusOr<RpeResult> rpe = ComputeRpe(gt, est, options);
  ASSERT_TRUE(rpe.ok()) << rpe.status().ToString();
  EXPECT_EQ(rpe->pairs.size(), 24u);
  EXPECT_NEAR(rpe->max_difference_s, 0.02, 1e-6);
  EXPECT_NEAR(rpe->translation_m.max, 0, 1e-9);
  // An explicit tolerance replaces the rule: 0.15 s lets 1.1 s and 1.4 s (0.1 s off) through.
  options.max_difference_s = 0.15;
  rpe = ComputeRpe(gt, est, options);
  ASSERT_TRUE(rpe.ok());
  EXPECT_EQ(rpe->pairs.size(), 26u);
  options.max_difference_s = 0.25;
  rpe = ComputeRpe(gt, est, options);
  ASSERT_TRUE(rpe.ok());
  EXPECT_EQ(rpe->pairs.size(), 29u);
}

TEST(RpeTest, IdenticalTrajectoriesHaveNoError) {
  const std::vector<StampedPose> gt = Drive(200, 33, 0.7, 25.0);
  StatusOr<RpeResult> rpe = ComputeRpe(gt, gt);
  ASSERT_TRUE(rpe.ok()) << rpe.status().ToString();
  EXPECT_LT(rpe->translation_m.max, 1e-12);
  EXPECT_LT(rpe->rotation_deg.max, 1e-5);
}

TEST(RpeTest, InvalidInputs) {
  const std::vector<StampedPose> gt = Drive(50, 100, 1.0, 0);
  RpeOptions options;
  options.delta = 0;
  EXPECT_EQ(ComputeRpe(gt, gt, options).status().code(), StatusCode::kInvalidArgument);
  options.delta = 1;
  options.max_difference_s = -1;
  EXPECT_EQ(ComputeRpe(gt, gt, options).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeRpe({gt[0]}, gt).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeRpe(gt, {}).status().code(), StatusCode::kInvalidArgument);
  // Delta longer than the trajectory: no pair.
  options = RpeOptions();
  options.delta = 100;
  EXPECT_EQ(ComputeRpe(gt, gt, options).status().code(), StatusCode::kInvalidArgument);
  // An estimate an hour after the ground truth does not overlap it.
  std::vector<StampedPose> late = gt;
  for (StampedPose& p : late) p.stamp_ns += 3600 * eval_test::kSecond;
  EXPECT_EQ(ComputeRpe(gt, late).status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
