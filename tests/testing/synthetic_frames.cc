#include "tests/testing/synthetic_frames.h"

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace semmap::testing {

CameraCalibration TestCamera(int width, int height) {
  CameraCalibration c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.8 * width;
  c.cx = width / 2.0;
  c.cy = height / 2.0;
  return c;
}

cv::Mat TexturedImage(int width, int height, int seed) {
  cv::Mat image(height, width, CV_8UC3);
  cv::RNG rng(static_cast<uint64_t>(seed) * 7919 + 1);
  rng.fill(image, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(image, image, cv::Size(5, 5), 1.2);
  for (int i = 0; i < 40; ++i) {
    // One draw per statement, last argument first: argument order is unspecified, and the
    // image must not depend on the compiler (this is the order gcc took).
    const int y = rng.uniform(0, height);
    const cv::Point p(rng.uniform(0, width), y);
    const int r = rng.uniform(0, 255), g = rng.uniform(0, 255), b = rng.uniform(0, 255);
    const int radius = rng.uniform(2, 12);
    cv::circle(image, p, radius, cv::Scalar(b, g, r), -1);
  }
  return image;
}

cv::Mat PlaneDepth(int width, int height) {
  cv::Mat depth(height, width, CV_16UC1);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      depth.at<uint16_t>(v, u) = static_cast<uint16_t>(5000.0 * (1.0 + 2.0 * u / width));
    }
  }
  return depth;
}

std::string EncodePng(const cv::Mat& image) {
  std::vector<uint8_t> buf;
  cv::imencode(".png", image, buf, {cv::IMWRITE_PNG_COMPRESSION, 1});
  return std::string(buf.begin(), buf.end());
}

std::vector<Eigen::Isometry3d> CircleTrajectory(int n, double radius) {
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / std::max(n, 1);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(radius * std::cos(a), 0.0, radius * std::sin(a));
    // Camera z axis points at the centre; y down.
    const Eigen::Vector3d z = -T.translation().normalized();
    const Eigen::Vector3d y(0, 1, 0);
    const Eigen::Vector3d x = y.cross(z).normalized();
    T.linear().col(0) = x;
    T.linear().col(1) = z.cross(x);
    T.linear().col(2) = z;
    poses.push_back(T);
  }
  return poses;
}

}  // namespace semmap::testing
