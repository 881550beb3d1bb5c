#include "tests/testing/synth/sequence_frame.h"

#include <algorithm>
#include <cmath>

#include "common/pose.h"
#include "tests/testing/synth/rng.h"

namespace semmap::synth {
namespace {

constexpr uint64_t kNoiseStream = 0x6E6F697365ULL;  // "noise"

// The pose `offset` frame intervals from frame i (|offset| <= 0.5), interpolated towards the
// neighbour on that side; the end frames extrapolate nothing (they hold still).
Eigen::Isometry3d PoseAtOffset(const std::vector<StampedPose>& trajectory, size_t i,
                               double offset) {
  const Eigen::Isometry3d& here = trajectory[i].T_world_camera;
  if (offset > 0 && i + 1 < trajectory.size()) {
    return InterpolatePose(here, trajectory[i + 1].T_world_camera, offset);
  }
  if (offset < 0 && i > 0) return InterpolatePose(here, trajectory[i - 1].T_world_camera, -offset);
  return here;
}

// How far (pixels) the scene seen in `frame` moves in the image between two poses: the largest
// reprojection shift over a grid of pixels with their rendered depth.
double ImageMotion(const CameraCalibration& c, const RenderedFrame& frame,
                   const Eigen::Isometry3d& T_world_from, const Eigen::Isometry3d& T_world_to) {
  const Eigen::Isometry3d T_to_from = T_world_to.inverse() * T_world_from;
  double most = 0;
  for (int gy = 0; gy < 7; ++gy) {
    for (int gx = 0; gx < 9; ++gx) {
      const int u = (2 * gx + 1) * c.width / 18, v = (2 * gy + 1) * c.height / 14;
      const double z = frame.depth.at<uint16_t>(v, u) / kDepthScale;
      if (z <= 0) continue;
      const Eigen::Vector3d p((u - c.cx) / c.fx * z, (v - c.cy) / c.fy * z, z);
      const Eigen::Vector3d q = T_to_from * p;
      if (q.z() <= 0.01) return 1e9;  // passes behind the camera: as much blur as allowed
      most = std::max(most,
                      std::hypot(c.fx * q.x() / q.z() + c.cx - u, c.fy * q.y() / q.z() + c.cy - v));
    }
  }
  return most;
}

}  // namespace

RenderedFrame RenderSequenceFrame(const Renderer& renderer,
                                  const std::vector<StampedPose>& trajectory, size_t index,
                                  const NoiseOptions& noise, uint64_t seed) {
  if (index >= trajectory.size()) return RenderedFrame{};
  RenderedFrame frame = renderer.Render(trajectory[index].T_world_camera);
  if (noise.motion_blur_samples >= 2) {
    const double half = 0.5 * noise.exposure;
    const Eigen::Isometry3d open = PoseAtOffset(trajectory, index, -half);
    const Eigen::Isometry3d close = PoseAtOffset(trajectory, index, half);
    // About one render per pixel of image motion (ghost copies further apart would show).
    const double motion = ImageMotion(renderer.camera(), frame, open, close);
    const int n = static_cast<int>(
        std::clamp(std::ceil(motion), 1.0, static_cast<double>(noise.motion_blur_samples)));
    if (n >= 2) {
      cv::Mat sum(frame.bgr.size(), CV_32FC3, cv::Scalar::all(0));
      RenderedFrame sub;
      for (int k = 0; k < n; ++k) {
        const double offset = noise.exposure * ((k + 0.5) / n - 0.5);
        renderer.Render(PoseAtOffset(trajectory, index, offset), &sub);
        for (int y = 0; y < sub.bgr.rows; ++y) {
          const uint8_t* in = sub.bgr.ptr<uint8_t>(y);
          float* acc = sum.ptr<float>(y);
          for (int x = 0; x < sub.bgr.cols * 3; ++x) acc[x] += in[x];
        }
      }
      sum.convertTo(frame.bgr, CV_8UC3, 1.0 / n);
    }
  }
  if (noise.depth_noise) {
    AddDepthNoise(noise, kDepthScale, DeriveSeed(seed, kNoiseStream, 3 * index), &frame.depth);
  }
  DropDepthPixels(noise.drop_depth_probability, DeriveSeed(seed, kNoiseStream, 3 * index + 1),
                  &frame.depth);
  AddColourNoise(noise.colour_noise_sigma, DeriveSeed(seed, kNoiseStream, 3 * index + 2),
                 &frame.bgr);
  return frame;
}

}  // namespace semmap::synth
