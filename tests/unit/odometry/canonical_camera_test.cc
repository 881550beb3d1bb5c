// The canonical camera resampling of the learned VO: the affine map of training/semmap_vo
// (config.py), coverage, and depth mapped back to the session's pixels.
#include "core/odometry/canonical_camera.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace semmap {
namespace {

CanonicalCamera Canonical() { return {128, 96, 105.0, 63.5, 47.5}; }

CameraCalibration Camera(int w, int h, double f) {
  CameraCalibration c;
  c.width = w;
  c.height = h;
  c.fx = c.fy = f;
  c.cx = (w - 1) / 2.0;
  c.cy = (h - 1) / 2.0;
  return c;
}

TEST(CanonicalCameraTest, APointMapsWhereTheAffineMapSays) {
  const CameraCalibration camera = Camera(640, 480, 525.0);
  StatusOr<CanonicalResampler> r = CanonicalResampler::Create(camera, Canonical());
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  // A bright square centred on source pixel (400, 300) lands at (f/fx)(u - cx) + cx'.
  cv::Mat image(480, 640, CV_8UC3, cv::Scalar(0, 0, 0));
  cv::rectangle(image, cv::Rect(390, 290, 21, 21), cv::Scalar(255, 255, 255), cv::FILLED);
  StatusOr<cv::Mat> canonical = r->ToCanonical(image);
  ASSERT_TRUE(canonical.ok());
  ASSERT_EQ(canonical->size(), cv::Size(128, 96));
  cv::Mat grey;
  cv::cvtColor(*canonical, grey, cv::COLOR_BGR2GRAY);
  const cv::Moments m = cv::moments(grey);
  const double s = 105.0 / 525.0;
  EXPECT_NEAR(m.m10 / m.m00, s * (400 - camera.cx) + 63.5, 0.25);
  EXPECT_NEAR(m.m01 / m.m00, s * (300 - camera.cy) + 47.5, 0.25);
}

TEST(CanonicalCameraTest, PixelsBeyondANarrowCameraAreBlackAndUncovered) {
  // A long lens (fx 1050 at 640 x 480) covers only the centre of the canonical image.
  StatusOr<CanonicalResampler> r =
      CanonicalResampler::Create(Camera(640, 480, 1050.0), Canonical());
  ASSERT_TRUE(r.ok());
  const cv::Mat white(480, 640, CV_8UC3, cv::Scalar(255, 255, 255));
  StatusOr<cv::Mat> canonical = r->ToCanonical(white);
  ASSERT_TRUE(canonical.ok());
  EXPECT_EQ(canonical->at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 0));
  EXPECT_EQ(canonical->at<cv::Vec3b>(48, 64), cv::Vec3b(255, 255, 255));
  EXPECT_EQ(r->coverage().at<uint8_t>(0, 0), 0);
  EXPECT_EQ(r->coverage().at<uint8_t>(48, 64), 255);
  // 640 px at half the focal length covers 32 canonical pixels each side of the centre.
  EXPECT_NEAR(cv::countNonZero(r->coverage()), 64 * 48, 2 * (64 + 48));
}

TEST(CanonicalCameraTest, DepthComesBackToTheCamerasPixels) {
  const CameraCalibration camera = Camera(320, 240, 262.5);  // the same field of view as 640 x 480
  StatusOr<CanonicalResampler> r = CanonicalResampler::Create(camera, Canonical());
  ASSERT_TRUE(r.ok());
  cv::Mat depth(96, 128, CV_32F, cv::Scalar(2.0f));
  depth(cv::Rect(64, 0, 64, 96)).setTo(3.0f);  // the right half is farther
  StatusOr<cv::Mat> raw = r->DepthToCamera(depth, 5000.0);
  ASSERT_TRUE(raw.ok()) << raw.status().ToString();
  ASSERT_EQ(raw->type(), CV_16UC1);
  ASSERT_EQ(raw->size(), cv::Size(320, 240));
  EXPECT_EQ(raw->at<uint16_t>(120, 20), 10000);
  EXPECT_EQ(raw->at<uint16_t>(120, 300), 15000);
  // Beyond the 16-bit range: no depth rather than a wrapped one.
  depth.setTo(20.0f);
  raw = r->DepthToCamera(depth, 5000.0);
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ(raw->at<uint16_t>(120, 160), 0);
  EXPECT_FALSE(r->DepthToCamera(cv::Mat(10, 10, CV_32F), 5000.0).ok());
}

TEST(CanonicalCameraTest, RefusesWhatItCannotResample) {
  EXPECT_EQ(CanonicalResampler::Create(Camera(640, 480, 1.0), Canonical()).status().code(),
            StatusCode::kInvalidArgument);  // 105x magnification
  CanonicalCamera bad = Canonical();
  bad.f = 0;
  EXPECT_EQ(CanonicalResampler::Create(Camera(640, 480, 525.0), bad).status().code(),
            StatusCode::kInvalidArgument);
  StatusOr<CanonicalResampler> r = CanonicalResampler::Create(Camera(640, 480, 525.0), Canonical());
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r->ToCanonical(cv::Mat(480, 641, CV_8UC3)).ok());
  EXPECT_FALSE(r->ToCanonical(cv::Mat(480, 640, CV_16UC1)).ok());
  EXPECT_TRUE(r->ToCanonical(cv::Mat(480, 640, CV_8UC1, cv::Scalar(7))).ok());  // grey is fine
}

}  // namespace
}  // namespace semmap
