// Shared fixtures of the odometry tests: the default synthetic room and rendered frames.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdlib>
#include <vector>

#include "common/camera.h"
#include "core/odometry/feature_extractor.h"
#include "tests/testing/synth/default_scene.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/sequence_writer.h"
#include "tests/testing/synth/trajectory.h"

namespace semmap::odometry_test {

// The default room (seed 1), built once per test process and never modified.
inline const synth::Scene& Room() {
  static const synth::Scene* const scene = [] {
    StatusOr<synth::Scene> s = synth::MakeDefaultRoomScene(1);
    if (!s.ok()) std::abort();
    return new synth::Scene(std::move(s).value());
  }();
  return *scene;
}

inline synth::Renderer MakeRenderer(const CameraCalibration& camera) {
  StatusOr<synth::Renderer> r = synth::Renderer::Create(Room(), camera);
  if (!r.ok()) std::abort();
  return std::move(r).value();
}

// `frames` poses of the circle trajectory through the default room.
inline std::vector<StampedPose> Circle(int frames) {
  synth::TrajectoryOptions options;
  options.frames = frames;
  StatusOr<std::vector<StampedPose>> poses = synth::CircleTrajectory(Room().room, options);
  if (!poses.ok()) std::abort();
  return std::move(poses).value();
}

inline FrameFeatures Extract(const FeatureExtractor& extractor, const synth::RenderedFrame& f) {
  StatusOr<FrameFeatures> features = extractor.Extract(f.bgr, f.depth, synth::kDepthScale);
  EXPECT_TRUE(features.ok()) << features.status().ToString();
  return features.ok() ? std::move(features).value() : FrameFeatures{};
}

inline Eigen::Vector2d Project(const CameraCalibration& c, const Eigen::Vector3d& p) {
  return Eigen::Vector2d(c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy);
}

inline double AngleDeg(const Eigen::Isometry3d& T) {
  return Eigen::AngleAxisd(T.linear()).angle() * 180.0 / 3.14159265358979;
}

}  // namespace semmap::odometry_test
