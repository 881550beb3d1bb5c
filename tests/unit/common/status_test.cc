#include "common/status.h"

#include <gtest/gtest.h>

namespace semmap {
namespace {

StatusOr<int> Half(int v) {
  if (v % 2 != 0) return InvalidArgumentError("odd");
  return v / 2;
}

Status UsesMacros(int v, int* out) {
  SEMMAP_ASSIGN_OR_RETURN(int h, Half(v));
  SEMMAP_RETURN_IF_ERROR(h > 10 ? OutOfRangeError("big") : OkStatus());
  *out = h;
  return OkStatus();
}

TEST(StatusTest, CodesAndMessages) {
  EXPECT_TRUE(OkStatus().ok());
  EXPECT_EQ(OkStatus().ToString(), "OK");
  const Status s = NotFoundError("no map 'x'");
  EXPECT_FALSE(s.ok());
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_EQ(s.ToString(), "NOT_FOUND: no map 'x'");
  EXPECT_EQ(s.WithContext("query").message(), "query: no map 'x'");
  EXPECT_EQ(DataLossError("x").code(), StatusCode::kDataLoss);
  EXPECT_EQ(StatusCodeName(StatusCode::kResourceExhausted), "RESOURCE_EXHAUSTED");
}

TEST(StatusTest, MacrosPropagate) {
  int out = 0;
  EXPECT_TRUE(UsesMacros(8, &out).ok());
  EXPECT_EQ(out, 4);
  EXPECT_EQ(UsesMacros(3, &out).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(UsesMacros(40, &out).code(), StatusCode::kOutOfRange);
}

}  // namespace
}  // namespace semmap
