#include "client/datasets/stamp_association.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <tuple>
#include <vector>

#include "tests/testing/all_pairs_association.h"
#include "tests/testing/units.h"

namespace semmap {
namespace {

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

// Found reviewing fuzz_tum_lists: the candidate pairs were listed first, and with stamps 1 ns
// apart every pair is within 20 ms, so two lists of 20000 lines (a 1 MB dataset) asked for
// 4e8 pairs (9.6 GB). Now memory grows with the lists, not their product.
TEST(AssociateStampsTest, DenseStampsNeedNoPairList) {
  std::vector<int64_t> a, b;
  for (int64_t i = 0; i < 20000; ++i) a.push_back(i);
  for (int64_t i = 19999; i >= 0; --i) b.push_back(i);
  const Partners p = AssociateStamps(a, b, kMax);
  ASSERT_EQ(p.size(), a.size());
  for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(p[i], a.size() - 1 - i) << i;
}

TEST(AssociateStampsTest, StampsAtTheEndsOfTheRange) {
  constexpr int64_t kMin = std::numeric_limits<int64_t>::min();
  constexpr int64_t kMaxStamp = std::numeric_limits<int64_t>::max();
  EXPECT_EQ(AssociateStamps({kMin, kMaxStamp}, {kMaxStamp - 1, kMin + 1}, kMax), (Partners{1, 0}));
  EXPECT_EQ(AssociateStamps({kMin}, {kMaxStamp}, kMax), (Partners{std::nullopt}));
}

TEST(AssociateStampsTest, EqualStampsPairInIndexOrder) {
  EXPECT_EQ(AssociateStamps({0, 0, 0}, {0, 0}, kMax), (Partners{0, 1, std::nullopt}));
  EXPECT_EQ(AssociateStamps({0}, {0}, 0), (Partners{std::nullopt}));
}

TEST(AssociateStampsTest, MatchesAllPairsGreedyOnRandomStampsWithTies) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 3000; ++trial) {
    const int range = 1 + static_cast<int>(rng() % 12);
    std::vector<int64_t> a(rng() % 9), b(rng() % 9);
    for (int64_t& s : a) s = static_cast<int64_t>(rng() % range);
    for (int64_t& s : b) s = static_cast<int64_t>(rng() % range);
    const int64_t max = 1 + static_cast<int64_t>(rng() % 5);
    ASSERT_EQ(AssociateStamps(a, b, max), testing::AssociateAllPairs(a, b, max))
        << "trial " << trial;
  }
}

TEST(AssociateStampsTest, EmptyInputs) {
  EXPECT_EQ(AssociateStamps({}, {1, 2}, kMax), Partners{});
  EXPECT_EQ(AssociateStamps({1, 2}, {}, kMax), (Partners{std::nullopt, std::nullopt}));
}

}  // namespace
}  // namespace semmap
