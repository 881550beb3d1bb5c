// The shared parsing helpers' edge cases (every reader relies on them).
#include "client/datasets/text_parse.h"

#include <gtest/gtest.h>

namespace semmap::datasets_internal {
namespace {

TEST(TextParseTest, SplitFieldsOnBlanksAndCommas) {
  const std::vector<std::string_view> fields = SplitFields(" 1, 2\t3 ,4,,5 ");
  EXPECT_EQ(fields, (std::vector<std::string_view>{"1", "2", "3", "4", "5"}));
  EXPECT_TRUE(SplitFields(" , ").empty());
}

TEST(TextParseTest, SplitLinesKeepsNumbering) {
  const std::vector<TextLine> lines = SplitLines("a\r\n\n  b  \nc");
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0].text, "a");
  EXPECT_EQ(lines[1].text, "");
  EXPECT_EQ(lines[2].text, "b");
  EXPECT_EQ(lines[3].number, 4);
  EXPECT_EQ(lines[3].text, "c");
}

TEST(TextParseTest, ParseDoubleNeedsTheWholeToken) {
  double v = 0;
  EXPECT_TRUE(ParseDouble("+1.5e-3", &v));
  EXPECT_DOUBLE_EQ(v, 1.5e-3);
  EXPECT_TRUE(ParseDouble("-2", &v));
  EXPECT_EQ(v, -2);
  EXPECT_FALSE(ParseDouble("1.5x", &v));
  EXPECT_FALSE(ParseDouble("", &v));
  EXPECT_FALSE(ParseDouble("+", &v));
  EXPECT_FALSE(ParseDouble("+-1", &v));
  int i = 0;
  EXPECT_TRUE(ParseInt("640", &i));
  EXPECT_EQ(i, 640);
  EXPECT_FALSE(ParseInt("640.0", &i));
  EXPECT_FALSE(ParseInt("99999999999", &i));
}

TEST(TextParseTest, ParseStampIsExactAndRangeChecked) {
  int64_t ns = 0;
  EXPECT_TRUE(ParseStamp("1341841873.273798", &ns));
  EXPECT_EQ(ns, 1341841873273798000LL);
  EXPECT_TRUE(ParseStamp("2.078941e-01", &ns));
  EXPECT_EQ(ns, 207'894'100);
  EXPECT_FALSE(ParseStamp("99999999999", &ns));
  EXPECT_FALSE(ParseStamp("1e300", &ns));
  EXPECT_FALSE(ParseStamp("nan", &ns));
  EXPECT_FALSE(ParseStamp("12:00", &ns));
}

}  // namespace
}  // namespace semmap::datasets_internal
