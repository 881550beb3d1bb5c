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

// Each side may be up to 16384, but every frame is decoded at the camera's size: the pixel
// count is capped too (a 16384 x 16384 camera would cost 1.3 GB per decoded RGB-D frame).
TEST(CameraTest, PixelCountIsCapped) {
  CameraCalibration c{8000, 6000, 5000, 5000, 4000, 3000};  // 48 MP
  EXPECT_TRUE(ValidateCalibration(c).ok());
  c = CameraCalibration{16384, 16384, 9000, 9000, 8192, 8192};
  const Status big = ValidateCalibration(c);
  EXPECT_EQ(big.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(big.message().find("more than 50 megapixels"), std::string::npos) << big.message();
}

}  // namespace
}  // namespace semmap
