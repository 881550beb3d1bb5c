// Renders colour and depth images of a synthetic Scene through a pinhole camera.
//
// Every surface (room planes, posters, box faces) is a textured rectangle. For a rectangle
// seen from its front, inverse depth and texture coordinates times inverse depth are affine
// in pixel coordinates, so each pixel costs a few multiply-adds, one division, a z-test and
// one bilinear texel fetch; rows are walked only across the rectangle's projected span
// (clipped at the near plane), nearest surfaces first so hidden pixels are rejected before
// shading. Texture level of detail comes from the texture-coordinate derivatives at each pixel
// (mip-mapped, so distant and grazing surfaces do not alias). Exact for the geometry: depth is
// z along the optical axis of the nearest surface through each pixel centre, quantised to
// 1/kDepthScale m. Single-threaded, deterministic, no OpenCV calls per frame.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <opencv2/core/mat.hpp>

#include "common/camera.h"
#include "common/status.h"
#include "tests/testing/synth/scene.h"

namespace semmap::synth {

// Raw depth units per metre, as TUM RGB-D depth PNGs store them.
inline constexpr double kDepthScale = 5000.0;

struct RenderedFrame {
  cv::Mat bgr;    // CV_8UC3
  cv::Mat depth;  // CV_16UC1, z in 1/kDepthScale m; 0 = nothing within 13.1 m (or no surface)
};

class Renderer {
 public:
  // Prepares the scene's textures (mip chains). The camera must be a valid pinhole without
  // distortion. The renderer keeps its own copy of what it needs from the scene.
  static StatusOr<Renderer> Create(const Scene& scene, const CameraCalibration& camera);

  // The same prepared scene seen through another camera (cheap: shares the textures).
  StatusOr<Renderer> WithCamera(const CameraCalibration& camera) const;

  RenderedFrame Render(const Eigen::Isometry3d& T_world_camera) const;
  // Renders into `frame`, reusing its buffers when they have the right size.
  void Render(const Eigen::Isometry3d& T_world_camera, RenderedFrame* frame) const;

  const CameraCalibration& camera() const { return camera_; }

 private:
  struct Prepared;  // textures and surfaces in render-ready form (renderer.cc)

  Renderer(std::shared_ptr<const Prepared> prepared, const CameraCalibration& camera)
      : prepared_(std::move(prepared)), camera_(camera) {}

  std::shared_ptr<const Prepared> prepared_;
  CameraCalibration camera_;
};

}  // namespace semmap::synth
