#include <gtest/gtest.h>

#include <chrono>

#include "common/rate_window.h"
#include "common/token_bucket.h"

namespace semmap {
namespace {

TEST(RateWindowTest, AdmitsAtMostNPerWindowAndForgetsOldEvents) {
  RateWindow window(2, std::chrono::seconds(60));
  const RateWindow::Clock::time_point t0{};
  EXPECT_TRUE(window.TryAcquire(t0));
  EXPECT_TRUE(window.TryAcquire(t0 + std::chrono::seconds(10)));
  EXPECT_FALSE(window.TryAcquire(t0 + std::chrono::seconds(59)));
  EXPECT_TRUE(window.TryAcquire(t0 + std::chrono::seconds(60)));  // the first has left
  EXPECT_FALSE(window.TryAcquire(t0 + std::chrono::seconds(61)));
  EXPECT_TRUE(window.TryAcquire(t0 + std::chrono::seconds(71)));
}

TEST(RateWindowTest, ZeroMeansNoLimit) {
  RateWindow window(0, std::chrono::seconds(60));
  for (int i = 0; i < 1000; ++i) EXPECT_TRUE(window.TryAcquire());
}

TEST(TokenBucketTest, PassesABurstThenTheRate) {
  const TokenBucket::Clock::time_point t0{};
  TokenBucket bucket(10, 20, t0);  // 10 per second, bursts of 20
  for (int i = 0; i < 20; ++i) EXPECT_TRUE(bucket.TryTake(t0)) << i;
  EXPECT_FALSE(bucket.TryTake(t0));
  EXPECT_FALSE(bucket.TryTake(t0 + std::chrono::milliseconds(99)));
  EXPECT_TRUE(bucket.TryTake(t0 + std::chrono::milliseconds(100)));
  EXPECT_FALSE(bucket.TryTake(t0 + std::chrono::milliseconds(150)));
  // A long pause refills to the burst, not beyond.
  const auto later = t0 + std::chrono::seconds(60);
  for (int i = 0; i < 20; ++i) EXPECT_TRUE(bucket.TryTake(later)) << i;
  EXPECT_FALSE(bucket.TryTake(later));
}

TEST(TokenBucketTest, AJitteryClientAtTheRateIsNeverRefused) {
  const TokenBucket::Clock::time_point t0{};
  TokenBucket bucket(30, 60, t0);
  // 30 Hz for a minute, each frame up to 20 ms late or early, in runs that bunch together.
  for (int i = 0; i < 1800; ++i) {
    const int jitter_ms = (i % 7) * 6 - 18;
    const auto at = t0 + std::chrono::milliseconds(1000 * i / 30 + 20 + jitter_ms);
    EXPECT_TRUE(bucket.TryTake(at)) << "frame " << i;
  }
}

TEST(TokenBucketTest, AClientTwiceTheRateIsRefusedWithinTheBurst) {
  const TokenBucket::Clock::time_point t0{};
  TokenBucket bucket(30, 60, t0);
  int passed = 0;
  int i = 0;
  for (; i < 600; ++i) {
    if (!bucket.TryTake(t0 + std::chrono::milliseconds(1000 * i / 60))) break;
    ++passed;
  }
  // 60 banked plus 30/s refill against 60/s: empty after about two seconds (120 frames).
  EXPECT_GT(passed, 110);
  EXPECT_LT(passed, 130);
}

}  // namespace
}  // namespace semmap
