// Small in-memory frame sources for pipeline and service tests: textured colour images, flat
// depth and a circular trajectory with known poses. (The full synthetic RGB-D scene renderer
// with objects and loops lives beside this once it exists.)
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "common/camera.h"

namespace semmap::testing {

CameraCalibration TestCamera(int width = 160, int height = 120);

// Deterministic, feature-rich BGR8 texture (different per seed).
cv::Mat TexturedImage(int width, int height, int seed);
// 16UC1 depth, a tilted plane 1..3 m away, in units of 1/5000 m.
cv::Mat PlaneDepth(int width, int height);
std::string EncodePng(const cv::Mat& image);

// n poses T_world_camera on a circle of `radius` metres, facing inwards.
std::vector<Eigen::Isometry3d> CircleTrajectory(int n, double radius = 1.0);

}  // namespace semmap::testing
