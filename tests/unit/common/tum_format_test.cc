#include "common/tum_format.h"

#include <gtest/gtest.h>

namespace semmap {
namespace {

TEST(TumFormatTest, StampTranslationAndCanonicalQuaternion) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(1.5, -2, 0.25);
  EXPECT_EQ(FormatTumPoseLine(1341841873273798000LL, T),
            "1341841873.273798 1.500000000 -2.000000000 0.250000000 0.000000000 0.000000000 "
            "0.000000000 1.000000000\n");
}

}  // namespace
}  // namespace semmap
