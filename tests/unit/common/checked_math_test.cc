#include "common/checked_math.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>

namespace semmap {
namespace {

constexpr uint64_t kMax = std::numeric_limits<uint64_t>::max();

TEST(CheckedMathTest, MultiplicationAtTheOverflowEdge) {
  EXPECT_EQ(CheckedMul(0, kMax), 0u);
  EXPECT_EQ(CheckedMul(1, kMax), kMax);
  EXPECT_EQ(CheckedMul(uint64_t{1} << 32, (uint64_t{1} << 32) - 1),
            kMax - ((uint64_t{1} << 32) - 1));
  EXPECT_FALSE(CheckedMul(uint64_t{1} << 32, uint64_t{1} << 32));
  EXPECT_FALSE(CheckedMul(2, (kMax / 2) + 1));
  EXPECT_EQ(CheckedMul(2, kMax / 2), kMax - 1);
}

TEST(CheckedMathTest, AdditionAtTheOverflowEdge) {
  EXPECT_EQ(CheckedAdd(kMax - 1, 1), kMax);
  EXPECT_FALSE(CheckedAdd(kMax, 1));
  EXPECT_FALSE(CheckedAdd(kMax / 2 + 1, kMax / 2 + 1));
}

// The image sizes of the hostile-client report: 2^31 x 2^31 x 4 bytes wraps to 0 in uint64.
TEST(CheckedMathTest, ImageSizesThatWrapAreCaught) {
  const uint64_t side = uint64_t{1} << 31;
  EXPECT_FALSE(CheckedProduct({side, side, 4}));
  EXPECT_EQ(CheckedProduct({side, side, 2}), uint64_t{1} << 63);
  EXPECT_FALSE(CheckedProduct({0xFFFFFFFFu, 0xFFFFFFFFu, 3}));
  EXPECT_EQ(CheckedProduct({640, 480, 3}), 921600u);
  EXPECT_EQ(CheckedProduct({}), 1u);
  EXPECT_EQ(CheckedProduct({0, kMax, kMax}), 0u);
}

TEST(CheckedMathTest, NarrowingKeepsOnlyWhatFits) {
  EXPECT_EQ(CheckedNarrow<int>(2147483647u), 2147483647);
  EXPECT_FALSE(CheckedNarrow<int>(2147483648u));
  EXPECT_EQ(CheckedNarrow<int64_t>(uint64_t{1} << 62), int64_t{1} << 62);
  EXPECT_FALSE(CheckedNarrow<int64_t>(uint64_t{1} << 63));
  EXPECT_EQ(CheckedNarrow<uint32_t>(0xFFFFFFFFu), 0xFFFFFFFFu);
  EXPECT_FALSE(CheckedNarrow<uint32_t>(uint64_t{1} << 32));
  EXPECT_EQ(CheckedNarrow<uint64_t>(kMax), kMax);
}

}  // namespace
}  // namespace semmap
