#include "common/camera.h"

#include <gtest/gtest.h>

#include <limits>

namespace semmap {
namespace {

CameraCalibration Tum() {
  CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = 535.4;
  c.fy = 539.2;
  c.cx = 320.1;
  c.cy = 247.6;
  return c;
}

TEST(CameraTest, AcceptsValidAndRejectsDegenerate) {
  EXPECT_TRUE(ValidateCalibration(Tum()).ok());
  CameraCalibration c = Tum();
  c.fx = 0;
  EXPECT_EQ(ValidateCalibration(c).code(), StatusCode::kInvalidArgument);
  c = Tum();
  c.cy = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(ValidateCalibration(c).code(), StatusCode::kInvalidArgument);
  c = Tum();
  c.width = 0;
  EXPECT_EQ(ValidateCalibration(c).code(), StatusCode::kInvalidArgument);
  c = Tum();
  c.distortion[0] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(ValidateCalibration(c).code(), StatusCode::kInvalidArgument);
  c = Tum();
  c.cx = 5000;
  EXPECT_EQ(ValidateCalibration(c).code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
