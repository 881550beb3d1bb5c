#include "common/tum_format.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

namespace semmap {
namespace {

TEST(TumFormatTest, StampTranslationAndCanonicalQuaternion) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(1.5, -2, 0.25);
  EXPECT_EQ(FormatTumPoseLine(1341841873273798000LL, T),
            "1341841873.273798 1.500000000 -2.000000000 0.250000000 0.000000000 0.000000000 "
            "0.000000000 1.000000000\n");
}

// fuzz_trajectory writes KITTI poses (no position bound) as TUM: a 256-byte buffer cut lines
// with a large finite translation, newline included, so the next line ran into it.
TEST(TumFormatTest, LargeTranslationKeepsTheWholeLine) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(1e300, -1e300, 1e308);
  const std::string line = FormatTumPoseLine(1, T);
  ASSERT_FALSE(line.empty());
  EXPECT_EQ(line.back(), '\n');
  EXPECT_GT(line.size(), 900u);
  EXPECT_EQ(line.find('\n'), line.size() - 1);
  EXPECT_NE(line.find(" 0.000000000 0.000000000 0.000000000 1.000000000\n"), std::string::npos);
  EXPECT_EQ(std::count(line.begin(), line.end(), ' '), 7);
}

}  // namespace
}  // namespace semmap
