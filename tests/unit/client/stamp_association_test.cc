#include "client/datasets/stamp_association.h"

#include <gtest/gtest.h>

namespace semmap {
namespace {

constexpr int64_t kMs = 1'000'000;
constexpr int64_t kMax = 20 * kMs;
using Partners = std::vector<std::optional<size_t>>;

TEST(AssociateStampsTest, PairsNearestWithinThreshold) {
  const Partners p = AssociateStamps({0, 33 * kMs, 66 * kMs}, {1 * kMs, 34 * kMs, 67 * kMs}, kMax);
  EXPECT_EQ(p, (Partners{0, 1, 2}));
}

TEST(AssociateStampsTest, ThresholdIsStrict) {
  EXPECT_EQ(AssociateStamps({0}, {kMax}, kMax), (Partners{std::nullopt}));
  EXPECT_EQ(AssociateStamps({kMax}, {0}, kMax), (Partners{std::nullopt}));
  EXPECT_EQ(AssociateStamps({0}, {kMax - 1}, kMax), (Partners{0}));
  EXPECT_EQ(AssociateStamps({0}, {-(kMax - 1)}, kMax), (Partners{0}));
}

TEST(AssociateStampsTest, GreedyBySmallestDifferenceNotByOrder) {
  // b0 = 10 ms, b1 = -15 ms: |a0-b0| = 10, |a1-b0| = 1, |a0-b1| = 15, |a1-b1| = 26 (too far).
  // a1 takes b0 first (1 ms), so a0 falls back to b1. Pairing in colour order instead
  // (a0 -> its nearest b0) would leave a1 without depth.
  const Partners p = AssociateStamps({0, 11 * kMs}, {10 * kMs, -15 * kMs}, kMax);
  EXPECT_EQ(p, (Partners{1, 0}));
}

TEST(AssociateStampsTest, OneToOne) {
  // Three colour stamps around a single depth stamp: only the nearest gets it.
  const Partners p = AssociateStamps({0, 4 * kMs, 9 * kMs}, {5 * kMs}, kMax);
  EXPECT_EQ(p, (Partners{std::nullopt, 0, std::nullopt}));
  // And the reverse: one colour stamp, three depth stamps.
  EXPECT_EQ(AssociateStamps({5 * kMs}, {0, 9 * kMs, 4 * kMs}, kMax), (Partners{2}));
}

TEST(AssociateStampsTest, TiesGoToTheEarlierStamp) {
  // b = 5 ms is 5 ms from both a = 0 and a = 10 ms; the earlier colour stamp takes it.
  EXPECT_EQ(AssociateStamps({10 * kMs, 0}, {5 * kMs}, kMax), (Partners{std::nullopt, 0}));
  // a = 5 ms is 5 ms from b = 0 and b = 10 ms: the earlier depth stamp.
  EXPECT_EQ(AssociateStamps({5 * kMs}, {10 * kMs, 0}, kMax), (Partners{1}));
}

TEST(AssociateStampsTest, EmptyInputs) {
  EXPECT_EQ(AssociateStamps({}, {1, 2}, kMax), Partners{});
  EXPECT_EQ(AssociateStamps({1, 2}, {}, kMax), (Partners{std::nullopt, std::nullopt}));
}

}  // namespace
}  // namespace semmap
