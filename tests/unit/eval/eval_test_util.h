// Trajectory builders shared by the eval tests.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <vector>

#include "client/datasets/trajectory_io.h"
#include "tests/testing/units.h"

namespace semmap::eval_test {

constexpr int64_t kSecond = 1'000'000'000;
// A Unix-time origin like the TUM sequences', so stamps go through the double rounding the TUM
// scripts apply.
constexpr int64_t kT0 = 1'341'841'873'415'100'000;

inline StampedPose MakePose(int64_t stamp_ns, const Eigen::Vector3d& position,
                            const Eigen::Matrix3d& rotation = Eigen::Matrix3d::Identity()) {
  StampedPose p;
  p.stamp_ns = stamp_ns;
  p.T_world_camera.linear() = rotation;
  p.T_world_camera.translation() = position;
  return p;
}

inline Eigen::Matrix3d Rot(double angle_rad, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
}

// A rising helix (not planar, not collinear), `n` poses `step_ns` apart, looking along the path.
inline std::vector<StampedPose> Helix(size_t n, int64_t step_ns = 10 * kMs, int64_t t0 = kT0) {
  std::vector<StampedPose> out;
  for (size_t i = 0; i < n; ++i) {
    const double a = 0.05 * static_cast<double>(i);
    out.push_back(MakePose(t0 + static_cast<int64_t>(i) * step_ns,
                           {2.0 * std::cos(a), 2.0 * std::sin(a), 0.01 * static_cast<double>(i)},
                           Rot(a, Eigen::Vector3d::UnitZ())));
  }
  return out;
}

// Every pose moved by T (applied on the left: T * pose), positions scaled first by `scale`.
inline std::vector<StampedPose> Transformed(const std::vector<StampedPose>& poses,
                                            const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                                            double scale = 1.0) {
  std::vector<StampedPose> out = poses;
  for (StampedPose& p : out) {
    p.T_world_camera.translation() = R * (scale * p.T_world_camera.translation()) + t;
    p.T_world_camera.linear() = R * p.T_world_camera.linear();
  }
  return out;
}

}  // namespace semmap::eval_test
