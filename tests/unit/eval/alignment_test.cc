#include "client/eval/alignment.h"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/unit/eval/eval_test_util.h"

namespace semmap {
namespace {

using eval_test::Rot;
using V = Eigen::Vector3d;

std::vector<V> Cloud() {
  return {{0, 0, 0}, {1, 0, 0}, {0, 2, 0}, {0, 0, 3}, {1, 1, 1}, {-2, 0.5, 0.3}};
}

std::vector<V> Moved(const std::vector<V>& points, const Eigen::Matrix3d& R, const V& t,
                     double s = 1.0) {
  std::vector<V> out;
  out.reserve(points.size());
  for (const V& p : points) out.emplace_back(s * (R * p) + t);
  return out;
}

TEST(AlignPointsTest, RecoversARigidMotion) {
  const Eigen::Matrix3d R = Rot(0.7, {1, -2, 0.5});
  const V t(0.3, -4, 2);
  const std::vector<V> target = Cloud();
  // source = R^-1 (target - t): aligning source onto target must give back R and t.
  std::vector<V> source;
  source.reserve(target.size());
  for (const V& p : target) source.emplace_back(R.transpose() * (p - t));
  StatusOr<Alignment> a = AlignPoints(source, target, false);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  EXPECT_LT((a->rotation - R).norm(), 1e-12);
  EXPECT_LT((a->translation - t).norm(), 1e-12);
  EXPECT_EQ(a->scale, 1.0);
  for (size_t i = 0; i < source.size(); ++i) {
    EXPECT_LT((a->Apply(source[i]) - target[i]).norm(), 1e-12);
  }
}

TEST(AlignPointsTest, RecoversASimilarity) {
  const Eigen::Matrix3d R = Rot(-1.1, {0.2, 1, 0.1});
  const std::vector<V> source = Cloud();
  const std::vector<V> target = Moved(source, R, {1, 2, 3}, 2.5);
  StatusOr<Alignment> a = AlignPoints(source, target, true);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  EXPECT_NEAR(a->scale, 2.5, 1e-12);
  EXPECT_LT((a->rotation - R).norm(), 1e-12);
  EXPECT_LT((a->translation - V(1, 2, 3)).norm(), 1e-12);
}

TEST(AlignPointsTest, NeverReturnsAReflection) {
  std::vector<V> source = Cloud();
  std::vector<V> target;
  target.reserve(source.size());
  for (const V& p : source) target.emplace_back(p.x(), p.y(), -p.z());  // mirror image
  StatusOr<Alignment> a = AlignPoints(source, target, false);
  ASSERT_TRUE(a.ok());
  EXPECT_NEAR(a->rotation.determinant(), 1.0, 1e-12);
  EXPECT_LT((a->rotation * a->rotation.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
}

TEST(AlignPointsTest, StraightLinesAreFine) {
  // Both collinear: every optimal rotation gives the same aligned points.
  std::vector<V> source, target;
  for (int i = 0; i < 10; ++i) {
    source.emplace_back(0, 0.5 * i, 0);
    target.emplace_back(1.0 * i, 2, 3);
  }
  StatusOr<Alignment> a = AlignPoints(source, target, true);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  EXPECT_NEAR(a->scale, 2.0, 1e-12);
  for (size_t i = 0; i < source.size(); ++i) {
    EXPECT_LT((a->Apply(source[i]) - target[i]).norm(), 1e-12);
  }
}

TEST(AlignPointsTest, TooFewOrMismatchedPointsAreInvalid) {
  EXPECT_EQ(AlignPoints({{0, 0, 0}, {1, 0, 0}}, {{0, 0, 0}, {1, 0, 0}}, false).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(AlignPoints(Cloud(), {{0, 0, 0}}, false).status().code(), StatusCode::kInvalidArgument);
  std::vector<V> bad = Cloud();
  bad[2].x() = std::nan("");
  EXPECT_EQ(AlignPoints(bad, Cloud(), false).status().code(), StatusCode::kInvalidArgument);
}

TEST(AlignPointsTest, StillTargetOrUncorrelatedOrRankOneIsAFailedPrecondition) {
  const std::vector<V> cloud = Cloud();
  const std::vector<V> five(cloud.begin(), cloud.begin() + 5);
  const std::vector<V> still(5, V(1, 2, 3));
  EXPECT_EQ(AlignPoints(still, five, false).status().code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(AlignPoints(five, still, false).status().code(), StatusCode::kFailedPrecondition);

  // A square in the x-y plane against points that only move in z, uncorrelated with it:
  // every rotation is equally good.
  const std::vector<V> square = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}};
  const std::vector<V> updown = {{0, 0, 1}, {0, 0, 1}, {0, 0, -1}, {0, 0, -1}};
  EXPECT_EQ(AlignPoints(square, updown, false).status().code(), StatusCode::kFailedPrecondition);

  // Neither set collinear, but the cross-covariance has rank 1: the rotation about one axis is
  // free and changes the per-point errors.
  const std::vector<V> triangle = {{1, 0, 0}, {-1, 0, 0}, {0, 0, 1}, {0, 0, 1}};
  StatusOr<Alignment> a = AlignPoints(square, triangle, false);
  EXPECT_EQ(a.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(a.status().message().find("degenerate"), std::string::npos);
}

}  // namespace
}  // namespace semmap
