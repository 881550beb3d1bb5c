// Shared helpers of the synthetic scene tests.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdlib>
#include <limits>
#include <optional>

#include "common/camera.h"
#include "tests/testing/pinhole_camera.h"
#include "tests/testing/synth/default_scene.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/scene.h"

namespace semmap::synth::test {

// The default room with seed 1, built once per test process.
inline const Scene& DefaultScene() {
  static const Scene* scene = [] {
    StatusOr<Scene> s = MakeDefaultRoomScene(1);
    if (!s.ok()) std::abort();
    return new Scene(std::move(s).value());
  }();
  return *scene;
}

inline CameraCalibration Camera640() { return testing::PinholeCamera(640, 480, 525); }

// The world point seen at pixel (u, v) with depth z metres.
inline Eigen::Vector3d Unproject(const CameraCalibration& c,
                                 const Eigen::Isometry3d& T_world_camera, double u, double v,
                                 double z) {
  return T_world_camera * Eigen::Vector3d((u - c.cx) / c.fx * z, (v - c.cy) / c.fy * z, z);
}

// Pixel coordinates of a world point, nullopt when behind the camera.
inline std::optional<Eigen::Vector2d> Project(const CameraCalibration& c,
                                              const Eigen::Isometry3d& T_world_camera,
                                              const Eigen::Vector3d& p_world) {
  const Eigen::Vector3d p = T_world_camera.inverse() * p_world;
  if (p.z() <= 1e-6) return std::nullopt;
  return Eigen::Vector2d(c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy);
}

// Distance from a point to a (finite) surface rectangle.
inline double DistanceToSurface(const Surface& s, const Eigen::Vector3d& p) {
  const Eigen::Vector3d rel = p - s.origin;
  const double a = std::clamp(rel.dot(s.u_axis), 0.0, s.width);
  const double b = std::clamp(rel.dot(s.v_axis), 0.0, s.height);
  return (p - s.PointAt(a, b)).norm();
}

// Reference ray cast, independent of the renderer: depth (z) of the nearest front-facing
// surface rectangle hit by the ray through pixel (u, v); +inf when none.
inline double ReferenceDepth(const std::vector<Surface>& surfaces, const CameraCalibration& c,
                             const Eigen::Isometry3d& T_world_camera, double u, double v) {
  const Eigen::Vector3d origin = T_world_camera.translation();
  const Eigen::Vector3d d_cam((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0);  // z = 1
  const Eigen::Vector3d d = T_world_camera.linear() * d_cam;
  double best = std::numeric_limits<double>::infinity();
  for (const Surface& s : surfaces) {
    const Eigen::Vector3d n = s.Normal();
    const double denom = n.dot(d);
    if (denom >= 0) continue;                           // parallel or seen from behind
    const double t = n.dot(s.origin - origin) / denom;  // = z, since d has unit z
    if (t <= 0 || t >= best) continue;
    const Eigen::Vector3d rel = origin + t * d - s.origin;
    const double a = rel.dot(s.u_axis), b = rel.dot(s.v_axis);
    if (a >= 0 && a <= s.width && b >= 0 && b <= s.height) best = t;
  }
  return best;
}

}  // namespace semmap::synth::test
