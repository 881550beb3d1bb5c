#include "client/eval/ate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "tests/unit/eval/eval_test_util.h"

namespace semmap {
namespace {

using eval_test::Helix;
using eval_test::kT0;
using eval_test::MakePose;
using eval_test::Rot;
using eval_test::Transformed;

// A full circle of radius r in the x-y plane centred on the origin, n poses 10 ms apart.
std::vector<StampedPose> Circle(size_t n, double r) {
  std::vector<StampedPose> out;
  for (size_t i = 0; i < n; ++i) {
    const double a = 2 * std::numbers::pi * static_cast<double>(i) / static_cast<double>(n);
    out.push_back(MakePose(kT0 + static_cast<int64_t>(i) * 10 * kMs,
                           {r * std::cos(a), r * std::sin(a), 0}, Rot(a, {0, 0, 1})));
  }
  return out;
}

void ExpectAllStats(const ErrorStatistics& s, double value, double tolerance) {
  EXPECT_NEAR(s.rmse, value, tolerance);
  EXPECT_NEAR(s.mean, value, tolerance);
  EXPECT_NEAR(s.median, value, tolerance);
  EXPECT_NEAR(s.min, value, tolerance);
  EXPECT_NEAR(s.max, value, tolerance);
  EXPECT_NEAR(s.std, 0, tolerance);
}

TEST(AteTest, PureTranslationOffsetIsZeroAfterAlignment) {
  const std::vector<StampedPose> gt = Helix(200);
  StatusOr<AteResult> ate = ComputeAte(gt, Transformed(gt, Eigen::Matrix3d::Identity(), {1, 2, 3}));
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  EXPECT_EQ(ate->stats.count, 200u);
  EXPECT_EQ(ate->pairs.size(), 200u);
  ExpectAllStats(ate->stats, 0, 1e-12);
  EXPECT_LT((ate->alignment.translation - Eigen::Vector3d(-1, -2, -3)).norm(), 1e-12);
  EXPECT_LT((ate->alignment.rotation - Eigen::Matrix3d::Identity()).norm(), 1e-12);
}

TEST(AteTest, KnownRotationIsUndoneByTheAlignment) {
  const std::vector<StampedPose> gt = Helix(150);
  const Eigen::Matrix3d R = Rot(2.0, {1, 1, -0.3});
  StatusOr<AteResult> ate = ComputeAte(gt, Transformed(gt, R, {-5, 0.5, 7}));
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  ExpectAllStats(ate->stats, 0, 1e-12);
  EXPECT_LT((ate->alignment.rotation - R.transpose()).norm(), 1e-12);
  // The whole estimate comes back onto the ground truth, orientation included.
  ASSERT_EQ(ate->aligned_estimate.size(), gt.size());
  for (size_t i = 0; i < gt.size(); ++i) {
    EXPECT_LT(
        (ate->aligned_estimate[i].T_world_camera.matrix() - gt[i].T_world_camera.matrix()).norm(),
        1e-11);
  }
}

TEST(AteTest, KnownScaleWithoutAndWithScaleEstimation) {
  // Estimate = ground-truth circle (radius 2) at half size, rotated and moved. Rigid alignment
  // cannot fix the size: every pose is off by |1 - 0.5| * 2 = 1 m. A similarity fixes it with
  // scale 2.
  const std::vector<StampedPose> gt = Circle(100, 2.0);
  const std::vector<StampedPose> est = Transformed(gt, Rot(0.4, {0, 1, 1}), {3, -1, 0.5}, 0.5);
  StatusOr<AteResult> rigid = ComputeAte(gt, est);
  ASSERT_TRUE(rigid.ok()) << rigid.status().ToString();
  EXPECT_FALSE(rigid->scale_estimated);
  EXPECT_EQ(rigid->alignment.scale, 1.0);
  ExpectAllStats(rigid->stats, 1.0, 1e-12);

  AteOptions options;
  options.estimate_scale = true;
  StatusOr<AteResult> similar = ComputeAte(gt, est, options);
  ASSERT_TRUE(similar.ok()) << similar.status().ToString();
  EXPECT_TRUE(similar->scale_estimated);
  EXPECT_NEAR(similar->alignment.scale, 2.0, 1e-12);
  ExpectAllStats(similar->stats, 0, 1e-12);
}

TEST(AteTest, AlternatingOffsetPerpendicularToTheMotionGivesThatOffset) {
  // Circle in the x-y plane (even count), estimate lifted by +d, -d, +d, ... along z. The
  // offsets are uncorrelated with the positions, so the best alignment is the identity and
  // every error is d: rmse = mean = median = min = max = d, std = 0.
  const double d = 0.037;
  std::vector<StampedPose> gt = Circle(64, 1.5);
  std::vector<StampedPose> est = gt;
  for (size_t i = 0; i < est.size(); ++i) {
    est[i].T_world_camera.translation().z() += (i % 2 == 0 ? d : -d);
  }
  StatusOr<AteResult> ate = ComputeAte(gt, est);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  ExpectAllStats(ate->stats, d, 1e-12);
  // Moving the estimate rigidly changes nothing.
  ate = ComputeAte(gt, Transformed(est, Rot(1.0, {1, 2, 3}), {10, 20, 30}));
  ASSERT_TRUE(ate.ok());
  ExpectAllStats(ate->stats, d, 1e-12);
}

TEST(AteTest, NoiseOfTwoMagnitudesGivesTheirStatistics) {
  // Offsets along z of +a, +a, -a, -a, +b, +b, -b, -b, ... on a circle of 96 poses: the
  // pattern is uncorrelated with the circle's x and y (period-8 sign blocks, n a multiple of 8)
  // and sums to zero, so the identity is optimal and errors are a (half) and b (half).
  const double a = 0.01;
  const double b = 0.03;
  std::vector<StampedPose> gt = Circle(96, 1.0);
  std::vector<StampedPose> est = gt;
  for (size_t i = 0; i < est.size(); ++i) {
    const double magnitude = (i / 4) % 2 == 0 ? a : b;
    est[i].T_world_camera.translation().z() += (i / 2) % 2 == 0 ? magnitude : -magnitude;
  }
  StatusOr<AteResult> ate = ComputeAte(gt, est);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  EXPECT_NEAR(ate->stats.rmse, std::sqrt((a * a + b * b) / 2), 1e-9);
  EXPECT_NEAR(ate->stats.mean, (a + b) / 2, 1e-9);
  EXPECT_NEAR(ate->stats.median, (a + b) / 2, 1e-9);  // even count: mean of the middle two
  EXPECT_NEAR(ate->stats.std, (b - a) / 2, 1e-9);
  EXPECT_NEAR(ate->stats.min, a, 1e-9);
  EXPECT_NEAR(ate->stats.max, b, 1e-9);
}

TEST(AteTest, MissingAndShiftedStampsAreAssociatedWithinMaxDiff) {
  const std::vector<StampedPose> gt = Helix(300);  // 100 Hz
  // A 33 Hz estimate 3 ms late, one pose in five missing, rigidly moved.
  std::vector<StampedPose> est;
  for (size_t i = 0; i < gt.size(); i += 3) {
    if ((i / 3) % 5 == 4) continue;
    StampedPose p = gt[i];
    p.stamp_ns += 3 * kMs;
    est.push_back(p);
  }
  StatusOr<AteResult> ate = ComputeAte(gt, Transformed(est, Rot(0.3, {0, 0, 1}), {1, 1, 1}));
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  EXPECT_EQ(ate->pairs.size(), est.size());
  ExpectAllStats(ate->stats, 0, 1e-12);
  for (size_t k = 0; k < ate->pairs.size(); ++k) {
    EXPECT_EQ(ate->pairs[k].est_stamp_ns - ate->pairs[k].gt_stamp_ns, 3 * kMs);
    if (k > 0) {
      EXPECT_GT(ate->pairs[k].gt_stamp_ns, ate->pairs[k - 1].gt_stamp_ns);
    }
  }

  // With --max-diff 0.002 nothing is close enough.
  AteOptions tight;
  tight.max_difference_s = 0.002;
  EXPECT_EQ(ComputeAte(gt, est, tight).status().code(), StatusCode::kInvalidArgument);
}

TEST(AteTest, UnpairedEstimatePosesAreAlignedToo) {
  const std::vector<StampedPose> gt = Helix(100);
  std::vector<StampedPose> est = Transformed(gt, Rot(1.2, {1, 0, 0}), {0, 0, 4});
  est.push_back(MakePose(gt.back().stamp_ns + 5000 * kMs, {9, 9, 9}));  // 5 s after the end
  StatusOr<AteResult> ate = ComputeAte(gt, est);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  EXPECT_EQ(ate->pairs.size(), 100u);
  ASSERT_EQ(ate->aligned_estimate.size(), 101u);
  EXPECT_LT((ate->aligned_estimate.back().T_world_camera.translation() -
             ate->alignment.Apply(Eigen::Vector3d(9, 9, 9)))
                .norm(),
            1e-12);
}

TEST(AteTest, DuplicateStampsKeepTheLastPoseLikeTheScript) {
  const std::vector<StampedPose> gt = Helix(50);
  std::vector<StampedPose> est = gt;
  // A stale pose earlier in the file with the stamp of pose 10: replaced by the later line.
  est.insert(est.begin() + 5, MakePose(gt[10].stamp_ns, {100, 100, 100}));
  StatusOr<AteResult> ate = ComputeAte(gt, est);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  EXPECT_EQ(ate->est_duplicates_dropped, 1u);
  EXPECT_EQ(ate->pairs.size(), 50u);
  ExpectAllStats(ate->stats, 0, 1e-12);

  // The same bad pose after the good one wins instead.
  est = gt;
  est.push_back(MakePose(gt[10].stamp_ns, {100, 100, 100}));
  ate = ComputeAte(gt, est);
  ASSERT_TRUE(ate.ok());
  EXPECT_EQ(ate->est_duplicates_dropped, 1u);
  EXPECT_GT(ate->stats.max, 10);

  // Duplicates in the ground truth are counted as well.
  std::vector<StampedPose> gt_dup = gt;
  gt_dup.push_back(gt[3]);
  ate = ComputeAte(gt_dup, gt);
  ASSERT_TRUE(ate.ok());
  EXPECT_EQ(ate->gt_duplicates_dropped, 1u);
}

TEST(AteTest, TooFewPairsIsInvalidArgument) {
  const std::vector<StampedPose> gt = Helix(2);
  StatusOr<AteResult> ate = ComputeAte(gt, gt);
  EXPECT_EQ(ate.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(ate.status().message().find("at least 3"), std::string::npos);
  EXPECT_EQ(ComputeAte({}, {}).status().code(), StatusCode::kInvalidArgument);
  // No overlap in time at all.
  const std::vector<StampedPose> a = Helix(50, 10 * kMs, kT0);
  const std::vector<StampedPose> b = Helix(50, 10 * kMs, kT0 + 3600 * eval_test::kSecond);
  EXPECT_EQ(ComputeAte(a, b).status().code(), StatusCode::kInvalidArgument);
}

TEST(AteTest, DegenerateGeometryIsFailedPrecondition) {
  const std::vector<StampedPose> gt = Helix(50);
  std::vector<StampedPose> still = gt;
  for (StampedPose& p : still) p.T_world_camera.translation() = Eigen::Vector3d(1, 2, 3);
  StatusOr<AteResult> ate = ComputeAte(gt, still);
  EXPECT_EQ(ate.status().code(), StatusCode::kFailedPrecondition);
  ate = ComputeAte(still, gt);
  EXPECT_EQ(ate.status().code(), StatusCode::kFailedPrecondition);
  AteOptions options;
  options.estimate_scale = true;
  EXPECT_EQ(ComputeAte(gt, still, options).status().code(), StatusCode::kFailedPrecondition);
}

TEST(AteTest, StraightLineMotionIsEvaluated) {
  // Collinear ground truth (a car on a straight road): the alignment is unique up to a rotation
  // about the line, which does not change the errors.
  std::vector<StampedPose> gt, est, half;
  for (int i = 0; i < 40; ++i) {
    gt.push_back(MakePose(kT0 + i * 100 * kMs, {0, 0, 1.0 * i}));
    // Sideways by 5 cm in +, -, -, + blocks (uncorrelated with the motion).
    const double side = (i % 4 == 0 || i % 4 == 3) ? 0.05 : -0.05;
    est.push_back(MakePose(kT0 + i * 100 * kMs, {1.0 * i, 3 + side, 0}));
    half.push_back(MakePose(kT0 + i * 100 * kMs, {0.5 * i, 3, 0}));
  }
  StatusOr<AteResult> ate = ComputeAte(gt, est);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  ExpectAllStats(ate->stats, 0.05, 1e-12);

  AteOptions options;
  options.estimate_scale = true;
  ate = ComputeAte(gt, half, options);
  ASSERT_TRUE(ate.ok()) << ate.status().ToString();
  EXPECT_NEAR(ate->alignment.scale, 2.0, 1e-12);
  ExpectAllStats(ate->stats, 0, 1e-12);
}

TEST(AteTest, BadOptionsAreInvalidArgument) {
  const std::vector<StampedPose> gt = Helix(10);
  AteOptions options;
  options.max_difference_s = 0;
  EXPECT_EQ(ComputeAte(gt, gt, options).status().code(), StatusCode::kInvalidArgument);
  options.max_difference_s = std::nan("");
  EXPECT_EQ(ComputeAte(gt, gt, options).status().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
