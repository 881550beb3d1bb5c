// The learned VO network sees every camera through one canonical pinhole camera (its input
// size and focal length, fixed at training: training/semmap_vo/config.py). A session's images
// are resampled to it exactly as the training data was, so depth and translation come out
// metric whatever the session's intrinsics; the network's depth map is mapped back to the
// session's pixels for keyframes, map layers and the hybrid tracker.
//
// Source pixel (u, v) of a camera (fx, fy, cx, cy, undistorted) maps to canonical (u', v'):
//   u' = (f / fx) (u - cx) + cx',  v' = (f / fy) (v - cy) + cy'   (pixel centres at integers)
#pragma once

#include <opencv2/core/mat.hpp>

#include "common/camera.h"
#include "common/status.h"

namespace semmap {

struct CanonicalCamera {
  int width = 0;
  int height = 0;
  double f = 0;  // focal length in pixels, both axes
  double cx = 0;
  double cy = 0;

  // Positive size (at most 4096 per side), focal length and a principal point in the image.
  Status Validate() const;
};

class CanonicalResampler {
 public:
  // INVALID_ARGUMENT for an invalid camera or canonical camera, or a camera so narrow or wide
  // that the canonical image would be resampled by more than 64 times.
  static StatusOr<CanonicalResampler> Create(const CameraCalibration& camera,
                                             const CanonicalCamera& canonical);

  // BGR8 or mono8 of the camera's size -> canonical BGR8 (mono replicated), resampled as the
  // training data was: undistort (when the camera has distortion), INTER_AREA resize by
  // (f / fx, f / fy), then a translation with bilinear sampling; pixels whose ray leaves the
  // camera's image are black.
  StatusOr<cv::Mat> ToCanonical(const cv::Mat& image) const;
  // Canonical metric depth (CV_32F, metres) -> the camera's pixels as 16-bit depth at
  // `depth_scale` units per metre (0 where the canonical image does not reach, or beyond the
  // 16-bit range), bilinear between canonical pixels.
  StatusOr<cv::Mat> DepthToCamera(const cv::Mat& canonical_depth, double depth_scale) const;

  const CameraCalibration& camera() const { return camera_; }
  const CanonicalCamera& canonical() const { return canonical_; }
  // Canonical pixels whose ray falls inside the camera's image (CV_8U, 255 inside).
  const cv::Mat& coverage() const { return coverage_; }

 private:
  CanonicalResampler() = default;

  CameraCalibration camera_;
  CanonicalCamera canonical_;
  double sx_ = 1, sy_ = 1;             // canonical / camera focal lengths
  cv::Mat undistort_x_, undistort_y_;  // empty without distortion
  cv::Mat coverage_;
  cv::Mat depth_map_x_, depth_map_y_;  // camera pixel -> canonical position (DepthToCamera)
};

}  // namespace semmap
