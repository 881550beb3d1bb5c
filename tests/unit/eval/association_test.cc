#include "client/eval/association.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "client/datasets/stamp_association.h"
#include "tests/unit/eval/eval_test_util.h"

namespace semmap {
namespace {

using eval_test::MakePose;

std::vector<size_t> Firsts(const std::vector<StampMatch>& m) {
  std::vector<size_t> out;
  out.reserve(m.size());
  for (const StampMatch& x : m) out.push_back(x.first);
  return out;
}
std::vector<size_t> Seconds(const std::vector<StampMatch>& m) {
  std::vector<size_t> out;
  out.reserve(m.size());
  for (const StampMatch& x : m) out.push_back(x.second);
  return out;
}

TEST(TumStampSecondsTest, IsTheDoublePythonParses) {
  // The C++ compiler rounds these literals correctly, as Python's float() does.
  EXPECT_EQ(TumStampSeconds(1'500'000'000), 1.5);
  EXPECT_EQ(TumStampSeconds(103'875'200), 0.1038752);
  EXPECT_EQ(TumStampSeconds(1'341'841'873'415'100'000), 1341841873.4151);
  EXPECT_EQ(TumStampSeconds(1'341'841'873'273'798'000), 1341841873.273798);
  EXPECT_EQ(TumStampSeconds(1'341'841'873'273'798'123), 1341841873.273798123);
  EXPECT_EQ(TumStampSeconds(-1'500'000'000), -1.5);
  EXPECT_EQ(TumStampSeconds(-1'341'841'873'415'100'000), -1341841873.4151);
  EXPECT_EQ(TumStampSeconds(0), 0.0);
}

TEST(TumStampSecondsTest, AgreesWithStrtodOnManyStamps) {
  uint64_t x = 88172645463325252ull;  // xorshift: deterministic pseudo-random stamps
  for (int i = 0; i < 20000; ++i) {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    const int64_t ns = static_cast<int64_t>(x % 9'000'000'000'000'000'000ull);
    char text[64];
    std::snprintf(text, sizeof(text), "%lld.%09lld", static_cast<long long>(ns / 1'000'000'000),
                  static_cast<long long>(ns % 1'000'000'000));
    ASSERT_EQ(TumStampSeconds(ns), std::strtod(text, nullptr)) << text;
  }
}

TEST(DeduplicateTumTest, SortsAndKeepsTheLastOfEachStamp) {
  const std::vector<StampedPose> poses = {
      MakePose(3 * kMs, {3, 0, 0}), MakePose(1 * kMs, {1, 0, 0}), MakePose(3 * kMs, {33, 0, 0}),
      MakePose(2 * kMs, {2, 0, 0}), MakePose(3 * kMs, {333, 0, 0})};
  const TumTrajectory t = DeduplicateTum(poses);
  ASSERT_EQ(t.poses.size(), 3u);
  EXPECT_EQ(t.duplicates_dropped, 2u);
  EXPECT_EQ(t.poses[0].stamp_ns, 1 * kMs);
  EXPECT_EQ(t.poses[1].stamp_ns, 2 * kMs);
  EXPECT_EQ(t.poses[2].stamp_ns, 3 * kMs);
  EXPECT_EQ(t.poses[2].T_world_camera.translation().x(), 333);  // the last line wins
  EXPECT_EQ(t.seconds, (std::vector<double>{0.001, 0.002, 0.003}));
}

TEST(AssociateTumTest, GreedyOneToOneSortedByFirst) {
  // Colour/depth-style example: b0 = 10 ms, b1 = -15 ms; a1 = 11 ms takes b0 (1 ms) first, so
  // a0 = 0 falls back to b1 (15 ms).
  std::vector<StampMatch> m = AssociateTum({0, 0.011}, {-0.015, 0.010}, 0.02);
  EXPECT_EQ(Firsts(m), (std::vector<size_t>{0, 1}));
  EXPECT_EQ(Seconds(m), (std::vector<size_t>{0, 1}));
  // One second stamp, three first stamps: only the nearest gets it.
  m = AssociateTum({0, 0.004, 0.009}, {0.005}, 0.02);
  EXPECT_EQ(Firsts(m), (std::vector<size_t>{1}));
}

TEST(AssociateTumTest, ThresholdIsStrictInDoubleArithmetic) {
  EXPECT_TRUE(AssociateTum({0}, {0.02}, 0.02).empty());
  EXPECT_EQ(AssociateTum({0}, {0.0199}, 0.02).size(), 1u);
  EXPECT_TRUE(AssociateTum({}, {1, 2}, 0.02).empty());
  EXPECT_TRUE(AssociateTum({1, 2}, {}, 0.02).empty());
}

TEST(AssociateTumTest, ExactTwentyMillisecondsAtUnixTimeIsAcceptedLikeTheScript) {
  // 1341841873.4151 and 1341841873.4351 are 0.02 s apart exactly, but as doubles their
  // difference is 0.019999980926513672 < 0.02, so associate.py pairs them. Exact arithmetic
  // (AssociateStamps) does not.
  const int64_t a = 1'341'841'873'415'100'000;
  const int64_t b = a + 20 * kMs;
  EXPECT_EQ(AssociateTum({TumStampSeconds(a)}, {TumStampSeconds(b)}, 0.02).size(), 1u);
  EXPECT_FALSE(AssociateStamps({a}, {b}, 20 * kMs)[0].has_value());
}

TEST(AssociateTumTest, MidpointTiesFollowDoubleRoundingLikeTheScript) {
  // The estimate stamp ...277.2801 is exactly between ground-truth stamps ...277.2751 and
  // ...277.2851. In doubles the later one is closer, so associate.py pairs the later one (this
  // stamp is planted in tests/unit/eval/data/teddy_est_rigid.txt, checked against the script).
  // Exact arithmetic calls it a tie and takes the earlier one.
  const int64_t g1 = 1'341'841'877'275'100'000;
  const int64_t g2 = 1'341'841'877'285'100'000;
  const int64_t e = 1'341'841'877'280'100'000;
  const std::vector<StampMatch> m =
      AssociateTum({TumStampSeconds(g1), TumStampSeconds(g2)}, {TumStampSeconds(e)}, 0.02);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].first, 1u);
  EXPECT_EQ(AssociateStamps({e}, {g1, g2}, 20 * kMs)[0], std::optional<size_t>(0));
}

TEST(AssociateTumTest, AgreesWithAssociateStampsAwayFromTiesAndBounds) {
  // Irregular stamps at least 1 ms away from any tie or threshold: both rules agree.
  std::vector<int64_t> a, b;
  for (int i = 0; i < 400; ++i) a.push_back(eval_test::kT0 + i * 10 * kMs);
  for (int i = 0; i < 100; ++i) b.push_back(eval_test::kT0 + i * 33 * kMs + 2 * kMs + 137'000);
  std::vector<double> as, bs;
  for (int64_t s : a) as.push_back(TumStampSeconds(s));
  for (int64_t s : b) bs.push_back(TumStampSeconds(s));
  const std::vector<StampMatch> tum = AssociateTum(as, bs, 0.02);
  const std::vector<std::optional<size_t>> exact = AssociateStamps(a, b, 20 * kMs);
  size_t paired = 0;
  for (const StampMatch& m : tum) {
    EXPECT_EQ(exact[m.first], std::optional<size_t>(m.second));
    ++paired;
  }
  size_t exact_paired = 0;
  for (const auto& p : exact) exact_paired += p.has_value() ? 1 : 0;
  EXPECT_EQ(paired, exact_paired);
  EXPECT_EQ(paired, 100u);
}

TEST(FindClosestIndexTumTest, FindsTheClosestValue) {
  const std::vector<double> v = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9};
  EXPECT_EQ(FindClosestIndexTum(v, -5), 0u);
  EXPECT_EQ(FindClosestIndexTum(v, 0.2), 0u);
  EXPECT_EQ(FindClosestIndexTum(v, 3.4), 3u);
  EXPECT_EQ(FindClosestIndexTum(v, 3.6), 4u);
  EXPECT_EQ(FindClosestIndexTum(v, 7), 7u);
  EXPECT_EQ(FindClosestIndexTum(v, 100), 9u);
  EXPECT_EQ(FindClosestIndexTum({5}, 1), 0u);
}

TEST(FindClosestIndexTumTest, TiesGoToTheFirstVisited) {
  // Binary search over {0,1,2,3} for 1.5 visits 2 before 1: 2 wins the tie.
  EXPECT_EQ(FindClosestIndexTum({0, 1, 2, 3}, 1.5), 2u);
  // 0.5 is 0.5 from both 0 and 1: index 0 is the initial best, an equal difference found later
  // does not replace it.
  EXPECT_EQ(FindClosestIndexTum({0, 1, 2, 3}, 0.5), 0u);
}

}  // namespace
}  // namespace semmap
