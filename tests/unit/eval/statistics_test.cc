#include "client/eval/statistics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace semmap {
namespace {

TEST(StatisticsTest, MatchesNumpyOnAnEvenCount) {
  StatusOr<ErrorStatistics> s = ComputeStatistics({4, 1, 3, 2});
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_EQ(s->count, 4u);
  EXPECT_DOUBLE_EQ(s->rmse, std::sqrt(30.0 / 4));
  EXPECT_DOUBLE_EQ(s->mean, 2.5);
  EXPECT_DOUBLE_EQ(s->median, 2.5);           // mean of the two middle values
  EXPECT_DOUBLE_EQ(s->std, std::sqrt(1.25));  // population std (ddof 0)
  EXPECT_DOUBLE_EQ(s->min, 1);
  EXPECT_DOUBLE_EQ(s->max, 4);
}

TEST(StatisticsTest, OddCountMedianIsTheMiddleValue) {
  StatusOr<ErrorStatistics> s = ComputeStatistics({0.3, 0.1, 0.2});
  ASSERT_TRUE(s.ok());
  EXPECT_DOUBLE_EQ(s->median, 0.2);
}

TEST(StatisticsTest, SingleValue) {
  StatusOr<ErrorStatistics> s = ComputeStatistics({0.5});
  ASSERT_TRUE(s.ok());
  EXPECT_DOUBLE_EQ(s->rmse, 0.5);
  EXPECT_DOUBLE_EQ(s->std, 0);
}

TEST(StatisticsTest, ScaledMultipliesEveryValue) {
  const ErrorStatistics s = ComputeStatistics({1, 2, 3}).value().Scaled(10);
  EXPECT_EQ(s.count, 3u);
  EXPECT_DOUBLE_EQ(s.mean, 20);
  EXPECT_DOUBLE_EQ(s.median, 20);
  EXPECT_DOUBLE_EQ(s.max, 30);
  EXPECT_DOUBLE_EQ(s.std, 10 * std::sqrt(2.0 / 3));
}

TEST(StatisticsTest, RejectsEmptyAndNonFinite) {
  EXPECT_EQ(ComputeStatistics({}).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeStatistics({1, std::numeric_limits<double>::quiet_NaN()}).status().code(),
            StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeStatistics({std::numeric_limits<double>::infinity()}).status().code(),
            StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
