#include "common/latency_stats.h"

#include <gtest/gtest.h>

namespace semmap {
namespace {

TEST(LatencyStatsTest, NearestRankPercentiles) {
  LatencyStats stats("decode");
  for (int i = 100; i >= 1; --i) stats.Add(i);  // 1..100 ms, any order
  const LatencySummary s = stats.Summarize();
  EXPECT_EQ(s.name, "decode");
  EXPECT_EQ(s.count, 100u);
  EXPECT_DOUBLE_EQ(s.p50_ms, 50);
  EXPECT_DOUBLE_EQ(s.p95_ms, 95);
  EXPECT_DOUBLE_EQ(s.max_ms, 100);
  EXPECT_DOUBLE_EQ(s.mean_ms, 50.5);
}

TEST(LatencyStatsTest, EmptyAndSingle) {
  LatencyStats stats("x");
  EXPECT_EQ(stats.Summarize().count, 0u);
  stats.Add(3.5);
  EXPECT_DOUBLE_EQ(stats.Summarize().p95_ms, 3.5);
}

}  // namespace
}  // namespace semmap
