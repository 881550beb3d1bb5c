// The features of one frame as every module above the sensor sees them: keypoints,
// descriptors and each keypoint's 3D point from the registered depth image. Produced by
// odometry's FeatureExtractor; read by tracking, the SLAM back end, recognition and objects.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <opencv2/core.hpp>
#include <opencv2/core/types.hpp>
#include <vector>

namespace semmap {

// Everything per keypoint is index-aligned. Keypoint coordinates are undistorted pixels (the
// pinhole model with fx, fy, cx, cy alone) when the camera has distortion.
struct FrameFeatures {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;                         // one row per keypoint (CV_8U binary, CV_32F SIFT)
  std::vector<Eigen::Vector3d> points_camera;  // metres, camera frame; zero without depth
  std::vector<bool> has_depth;

  size_t size() const { return keypoints.size(); }
  size_t NumWithDepth() const;
  // Heap bytes the arrays hold (capacity, not size): what keeping these features costs.
  size_t HeldBytes() const;
  bool binary_descriptors() const { return descriptors.depth() == CV_8U; }
};

}  // namespace semmap
