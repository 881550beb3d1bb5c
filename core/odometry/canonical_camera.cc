#include "core/odometry/canonical_camera.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

namespace semmap {

Status CanonicalCamera::Validate() const {
  if (width <= 0 || height <= 0 || width > 4096 || height > 4096) {
    return InvalidArgumentError("canonical camera size must be in 1..4096 per side");
  }
  if (!std::isfinite(f) || f <= 0) {
    return InvalidArgumentError("canonical camera focal length must be positive");
  }
  if (!std::isfinite(cx) || !std::isfinite(cy) || cx < 0 || cy < 0 || cx > width - 1 ||
      cy > height - 1) {
    return InvalidArgumentError("canonical camera principal point must lie in its image");
  }
  return OkStatus();
}

StatusOr<CanonicalResampler> CanonicalResampler::Create(const CameraCalibration& camera,
                                                        const CanonicalCamera& canonical) {
  SEMMAP_RETURN_IF_ERROR(ValidateCalibration(camera).WithContext("camera"));
  SEMMAP_RETURN_IF_ERROR(canonical.Validate());
  CanonicalResampler r;
  r.camera_ = camera;
  r.canonical_ = canonical;
  r.sx_ = canonical.f / camera.fx;
  r.sy_ = canonical.f / camera.fy;
  for (const double s : {r.sx_, r.sy_}) {
    if (!(s >= 1.0 / 64 && s <= 64)) {
      return InvalidArgumentError(
          "the camera's focal length (" + std::to_string(camera.fx) + ", " +
          std::to_string(camera.fy) + " px) is too far from the VO network's (" +
          std::to_string(canonical.f) + " px at " + std::to_string(canonical.width) + "x" +
          std::to_string(canonical.height) + ")");
    }
  }
  if (camera.HasDistortion()) {
    const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    const cv::Mat distortion(1, 5, CV_64F, const_cast<double*>(camera.distortion.data()));
    cv::initUndistortRectifyMap(K, distortion, cv::Matx33d::eye(), K,
                                cv::Size(camera.width, camera.height), CV_32FC1, r.undistort_x_,
                                r.undistort_y_);
  }
  // Coverage: canonical pixel -> camera position inside [0, w-1] x [0, h-1].
  r.coverage_ = cv::Mat::zeros(canonical.height, canonical.width, CV_8U);
  for (int v = 0; v < canonical.height; ++v) {
    const double y = (v - canonical.cy) / r.sy_ + camera.cy;
    for (int u = 0; u < canonical.width; ++u) {
      const double x = (u - canonical.cx) / r.sx_ + camera.cx;
      if (x >= 0 && x <= camera.width - 1 && y >= 0 && y <= camera.height - 1) {
        r.coverage_.at<uint8_t>(v, u) = 255;
      }
    }
  }
  // Camera pixel -> canonical position, for mapping depth back: through the undistorted
  // pinhole position when the camera has distortion.
  r.depth_map_x_.create(camera.height, camera.width, CV_32F);
  r.depth_map_y_.create(camera.height, camera.width, CV_32F);
  std::vector<cv::Point2f> pixels;
  pixels.reserve(static_cast<size_t>(camera.width) * static_cast<size_t>(camera.height));
  for (int v = 0; v < camera.height; ++v) {
    for (int u = 0; u < camera.width; ++u)
      pixels.emplace_back(static_cast<float>(u), static_cast<float>(v));
  }
  if (camera.HasDistortion()) {
    const cv::Matx33d K(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    const cv::Mat distortion(1, 5, CV_64F, const_cast<double*>(camera.distortion.data()));
    std::vector<cv::Point2f> undistorted;
    cv::undistortPoints(pixels, undistorted, K, distortion, cv::noArray(), K);
    pixels.swap(undistorted);
  }
  size_t i = 0;
  for (int v = 0; v < camera.height; ++v) {
    auto* mx = r.depth_map_x_.ptr<float>(v);
    auto* my = r.depth_map_y_.ptr<float>(v);
    for (int u = 0; u < camera.width; ++u, ++i) {
      mx[u] = static_cast<float>(r.sx_ * (pixels[i].x - camera.cx) + canonical.cx);
      my[u] = static_cast<float>(r.sy_ * (pixels[i].y - camera.cy) + canonical.cy);
    }
  }
  return r;
}

StatusOr<cv::Mat> CanonicalResampler::ToCanonical(const cv::Mat& image) const {
  if (image.cols != camera_.width || image.rows != camera_.height ||
      (image.type() != CV_8UC3 && image.type() != CV_8UC1)) {
    return InvalidArgumentError("VO input must be BGR8 or mono8 of the camera's size");
  }
  cv::Mat bgr;
  if (image.type() == CV_8UC1) {
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  } else {
    bgr = image;
  }
  if (!undistort_x_.empty()) {
    cv::Mat undistorted;
    cv::remap(bgr, undistorted, undistort_x_, undistort_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    bgr = undistorted;
  }
  // As training/semmap_vo/data.py's to_canonical_rgb: INTER_AREA resize, then a translation.
  cv::Mat small;
  cv::resize(bgr, small, cv::Size(), sx_, sy_, cv::INTER_AREA);
  const double tx = 0.5 - 0.5 * sx_ - sx_ * camera_.cx + canonical_.cx;
  const double ty = 0.5 - 0.5 * sy_ - sy_ * camera_.cy + canonical_.cy;
  const cv::Matx23d shift(1, 0, tx, 0, 1, ty);
  cv::Mat out;
  cv::warpAffine(small, out, shift, cv::Size(canonical_.width, canonical_.height), cv::INTER_LINEAR,
                 cv::BORDER_CONSTANT, cv::Scalar::all(0));
  out.setTo(cv::Scalar::all(0), ~coverage_);
  return out;
}

StatusOr<cv::Mat> CanonicalResampler::DepthToCamera(const cv::Mat& canonical_depth,
                                                    double depth_scale) const {
  if (canonical_depth.type() != CV_32FC1 || canonical_depth.cols != canonical_.width ||
      canonical_depth.rows != canonical_.height) {
    return InvalidArgumentError("canonical depth must be CV_32F of the canonical size");
  }
  if (!std::isfinite(depth_scale) || depth_scale <= 0) {
    return InvalidArgumentError("depth scale must be positive");
  }
  cv::Mat metres;
  cv::remap(canonical_depth, metres, depth_map_x_, depth_map_y_, cv::INTER_LINEAR,
            cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat raw;
  metres.convertTo(raw, CV_32F, depth_scale);
  raw.setTo(0, raw > 65535.0);
  raw.setTo(0, raw != raw);  // NaN
  cv::Mat out;
  raw.convertTo(out, CV_16U);
  return out;
}

}  // namespace semmap
