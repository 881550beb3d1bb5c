// Helpers shared by the storage tests: small records (TempDir comes from tests/testing).
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "common/map_types.h"
#include "common/status.h"
#include "tests/testing/temp_dir.h"

namespace semmap::storage_test {

using TempDir = testing::TempDir;

inline Eigen::Isometry3d PoseAt(double x, double yaw = 0) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, 2 * x, -x);
  return T;
}

inline TrajectoryPose FramePose(int64_t seq, bool is_keyframe = false) {
  TrajectoryPose p;
  p.seq = seq;
  p.stamp_ns = 1'000'000'000 + seq * 33'000'000;
  p.T_world_camera = PoseAt(0.1 * static_cast<double>(seq), 0.01 * static_cast<double>(seq));
  p.is_keyframe = is_keyframe;
  return p;
}

inline KeyframeRecord Keyframe(int64_t session_id, int64_t seq) {
  KeyframeRecord kf;
  kf.session_id = session_id;
  kf.seq = seq;
  kf.stamp_ns = FramePose(seq).stamp_ns;
  kf.T_world_camera = FramePose(seq).T_world_camera;
  kf.colour = {"jpeg", "colour-bytes-" + std::to_string(seq)};
  kf.depth = {"png", std::string("\0depth\xff", 7)};
  kf.depth_scale = 5000;
  return kf;
}

inline SessionInfo NewSession(int64_t map_id, const std::string& name) {
  SessionInfo s;
  s.map_id = map_id;
  s.name = name;
  s.mode = SessionMode::kRgbd;
  s.camera.width = 640;
  s.camera.height = 480;
  s.camera.fx = 525;
  s.camera.fy = 526;
  s.camera.cx = 319.5;
  s.camera.cy = 239.5;
  s.camera.distortion = {0.1, -0.2, 0.001, 0.002, 0.03};
  s.depth_scale = 5000;
  s.started_unix_ns = 1'700'000'000'000'000'000;
  return s;
}

inline void ExpectPoseNear(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  EXPECT_TRUE(a.isApprox(b, 1e-9)) << a.matrix() << "\nvs\n" << b.matrix();
}

}  // namespace semmap::storage_test

#define ASSERT_OK(expr)                                                  \
  do {                                                                   \
    const ::semmap::Status& assert_ok_status_ = (expr);                  \
    ASSERT_TRUE(assert_ok_status_.ok()) << assert_ok_status_.ToString(); \
  } while (false)
#define EXPECT_OK(expr)                                                  \
  do {                                                                   \
    const ::semmap::Status& expect_ok_status_ = (expr);                  \
    EXPECT_TRUE(expect_ok_status_.ok()) << expect_ok_status_.ToString(); \
  } while (false)
