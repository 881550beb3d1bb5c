#include "common/time_util.h"

#include <gtest/gtest.h>

namespace semmap {
namespace {

TEST(TimeUtilTest, ParsesExactly) {
  int64_t ns = 0;
  ASSERT_TRUE(ParseStampSeconds("1341841873.273798", &ns));
  EXPECT_EQ(ns, 1341841873273798000LL);
  ASSERT_TRUE(ParseStampSeconds("12", &ns));
  EXPECT_EQ(ns, 12'000'000'000LL);
  ASSERT_TRUE(ParseStampSeconds("1.038752e-01", &ns));
  EXPECT_EQ(ns, 103875200LL);
  EXPECT_FALSE(ParseStampSeconds("", &ns));
  EXPECT_FALSE(ParseStampSeconds("abc", &ns));
  EXPECT_FALSE(ParseStampSeconds("1.5x", &ns));
  EXPECT_FALSE(ParseStampSeconds("99999999999", &ns));  // would overflow int64 nanoseconds
  EXPECT_FALSE(ParseStampSeconds("1e300", &ns));
}

TEST(TimeUtilTest, FormatsMicroseconds) {
  EXPECT_EQ(FormatStampSeconds(1341841873273798000LL), "1341841873.273798");
  EXPECT_EQ(FormatStampSeconds(1'500'000'499LL), "1.500000");
  EXPECT_EQ(FormatStampSeconds(0), "0.000000");
}

}  // namespace
}  // namespace semmap
