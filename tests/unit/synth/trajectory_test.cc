#include "tests/testing/synth/trajectory.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "common/pose.h"

namespace semmap::synth {
namespace {

using Eigen::Vector3d;

const Eigen::AlignedBox3d kRoom(Vector3d(-3, -2.5, 0), Vector3d(3, 2.5, 2.8));
constexpr TrajectoryKind kAllKinds[] = {TrajectoryKind::kCircle, TrajectoryKind::kFigureEight,
                                        TrajectoryKind::kCorridorLoop,
                                        TrajectoryKind::kPureRotation, TrajectoryKind::kFastMotion};
constexpr TrajectoryKind kLoops[] = {TrajectoryKind::kCircle, TrajectoryKind::kFigureEight,
                                     TrajectoryKind::kCorridorLoop, TrajectoryKind::kPureRotation};

std::vector<StampedPose> Make(TrajectoryKind kind, const TrajectoryOptions& options = {}) {
  StatusOr<std::vector<StampedPose>> poses = MakeTrajectory(kind, kRoom, options);
  EXPECT_TRUE(poses.ok()) << poses.status().ToString();
  return poses.ok() ? *poses : std::vector<StampedPose>{};
}

double Degrees(double radians) { return radians * 180.0 / 3.14159265358979323846; }

TEST(TrajectoryTest, LookingPoseUsesOpenCvCameraAxes) {
  const Eigen::Isometry3d T = LookingPose(Vector3d(1, 2, 3), 0.0, 0.0);
  EXPECT_TRUE(T.linear().col(2).isApprox(Vector3d::UnitX()));   // looks along +x
  EXPECT_TRUE(T.linear().col(1).isApprox(-Vector3d::UnitZ()));  // image down = world down
  EXPECT_TRUE(T.linear().col(0).isApprox(-Vector3d::UnitY()));  // image right
  EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
  const Eigen::Isometry3d up = LookingPose(Vector3d::Zero(), 1.0, 0.4, 0.2);
  EXPECT_GT(up.linear().col(2).z(), 0.3);  // positive pitch looks up
  EXPECT_TRUE((up.linear().transpose() * up.linear()).isIdentity(1e-12));
}

TEST(TrajectoryTest, StampsFollowTheRate) {
  TrajectoryOptions options;
  options.frames = 10;
  options.rate_hz = 20.0;
  options.start_stamp_ns = 5'000'000'000;
  for (TrajectoryKind kind : kAllKinds) {
    const std::vector<StampedPose> poses = Make(kind, options);
    ASSERT_EQ(poses.size(), 10u);
    for (size_t i = 0; i < poses.size(); ++i) {
      EXPECT_EQ(poses[i].stamp_ns, 5'000'000'000 + static_cast<int64_t>(i) * 50'000'000);
    }
  }
}

TEST(TrajectoryTest, StaysInsideTheRoomLookingSlightlyDown) {
  const Eigen::AlignedBox3d free_zone(Vector3d(-2.0, -1.4, 0.8), Vector3d(2.0, 1.4, 1.8));
  for (TrajectoryKind kind : kAllKinds) {
    SCOPED_TRACE(std::string(TrajectoryKindName(kind)));
    for (const StampedPose& p : Make(kind)) {
      EXPECT_TRUE(free_zone.contains(p.T_world_camera.translation()))
          << p.T_world_camera.translation().transpose();
      const Vector3d forward = p.T_world_camera.linear().col(2);
      EXPECT_LT(forward.z(), 0.2);   // never up at the ceiling
      EXPECT_GT(forward.z(), -0.6);  // nor straight at the floor
      EXPECT_TRUE(
          (p.T_world_camera.linear().transpose() * p.T_world_camera.linear()).isIdentity(1e-9));
    }
  }
}

TEST(TrajectoryTest, LoopsRevisitTheirStart) {
  for (TrajectoryKind kind : kLoops) {
    SCOPED_TRACE(std::string(TrajectoryKindName(kind)));
    const std::vector<StampedPose> poses = Make(kind);
    const Eigen::Isometry3d delta =
        poses.front().T_world_camera.inverse() * poses.back().T_world_camera;
    EXPECT_LT(delta.translation().norm(), 0.02);
    EXPECT_LT(Degrees(RotationAngle(delta)), 1.0);
    // ...after going somewhere: the middle of the lap is far in position or direction.
    const Eigen::Isometry3d half =
        poses.front().T_world_camera.inverse() * poses[poses.size() / 2].T_world_camera;
    EXPECT_TRUE(half.translation().norm() > 1.0 || Degrees(RotationAngle(half)) > 60.0);
  }
}

TEST(TrajectoryTest, MotionIsSmoothForLoopsAndQuickForFastMotion) {
  for (TrajectoryKind kind : kAllKinds) {
    SCOPED_TRACE(std::string(TrajectoryKindName(kind)));
    const std::vector<StampedPose> poses = Make(kind);
    double max_step = 0, max_turn = 0, mean_speed = 0;
    for (size_t i = 1; i < poses.size(); ++i) {
      const Eigen::Isometry3d d = poses[i - 1].T_world_camera.inverse() * poses[i].T_world_camera;
      max_step = std::max(max_step, d.translation().norm());
      max_turn = std::max(max_turn, Degrees(RotationAngle(d)));
      mean_speed += d.translation().norm() * 30.0 / (poses.size() - 1);
    }
    if (kind == TrajectoryKind::kFastMotion) {
      EXPECT_GT(mean_speed, 0.8);  // m/s
      EXPECT_GT(max_turn, 4.0);    // deg per frame
    } else {
      EXPECT_LT(max_step, 0.05);
      EXPECT_LT(max_turn, 3.0);  // 90 deg/s at 30 Hz; the figure-eight comes closest
    }
  }
}

TEST(TrajectoryTest, PureRotationDoesNotTranslate) {
  const std::vector<StampedPose> poses = Make(TrajectoryKind::kPureRotation);
  for (const StampedPose& p : poses) {
    EXPECT_LT((p.T_world_camera.translation() - poses[0].T_world_camera.translation()).norm(),
              1e-12);
  }
}

TEST(TrajectoryTest, FastMotionDependsOnTheSeedOnly) {
  TrajectoryOptions a, b;
  b.seed = 99;
  const std::vector<StampedPose> p1 = Make(TrajectoryKind::kFastMotion, a);
  const std::vector<StampedPose> p2 = Make(TrajectoryKind::kFastMotion, a);
  const std::vector<StampedPose> p3 = Make(TrajectoryKind::kFastMotion, b);
  EXPECT_TRUE(p1[100].T_world_camera.isApprox(p2[100].T_world_camera, 0));
  EXPECT_GT((p1[100].T_world_camera.translation() - p3[100].T_world_camera.translation()).norm() +
                RotationAngle(p1[100].T_world_camera.inverse() * p3[100].T_world_camera),
            0.05);
}

// Four stops like the default room's objects: two on walls, one low on the floor, one on the
// desk.
TrajectoryOptions TourOptions() {
  TrajectoryOptions options;
  options.tour_targets = {{Vector3d(0.7, 2.5, 1.0), Vector3d(0, -1, 0)},
                          {Vector3d(2.4, -0.7, 0.9), Vector3d(-1, 0, 0)},
                          {Vector3d(-1.1, -2.5, 1.5), Vector3d(0, 1, 0)},
                          {Vector3d(-2.5, -0.5, 0.2), Vector3d(1, 0, 0)}};
  return options;
}

TEST(TrajectoryTest, TourLooksAtEachTargetFromItsDistanceAndComesBack) {
  const TrajectoryOptions options = TourOptions();
  const std::vector<StampedPose> poses = Make(TrajectoryKind::kTour, options);
  ASSERT_EQ(poses.size(), 300u);
  const size_t per_stop = poses.size() / options.tour_targets.size();
  for (size_t k = 0; k < options.tour_targets.size(); ++k) {
    const Vector3d target = options.tour_targets[k].point;
    // Through the stop's sideways step the target stays in the middle of the view.
    for (size_t i = k * per_stop; i < k * per_stop + per_stop * 4 / 10; ++i) {
      const Eigen::Isometry3d& T = poses[i].T_world_camera;
      const Vector3d p = T.inverse() * target;
      ASSERT_GT(p.z(), 0.5) << "stop " << k << " frame " << i;
      EXPECT_LT(std::hypot(p.x(), p.y()) / p.z(), 0.01) << "stop " << k << " frame " << i;
      const Vector3d d = target - T.translation();
      EXPECT_NEAR(std::hypot(d.x(), d.y()), 1.0, 0.16);
      EXPECT_TRUE(kRoom.contains(T.translation()));
    }
  }
  const Eigen::Isometry3d delta =
      poses.front().T_world_camera.inverse() * poses.back().T_world_camera;
  EXPECT_LT(delta.translation().norm(), 0.02);
  double max_step = 0;
  for (size_t i = 1; i < poses.size(); ++i) {
    max_step = std::max(
        max_step,
        (poses[i].T_world_camera.translation() - poses[i - 1].T_world_camera.translation()).norm());
  }
  EXPECT_LT(max_step, 0.1);
  TrajectoryOptions none;
  EXPECT_EQ(TourTrajectory(kRoom, none).status().code(), StatusCode::kInvalidArgument);
  TrajectoryOptions vertical = TourOptions();
  vertical.tour_targets[0].normal = Vector3d::UnitZ();
  EXPECT_EQ(TourTrajectory(kRoom, vertical).status().code(), StatusCode::kInvalidArgument);
}

// Three laps over 3n + 1 frames pass frame k of the single lap over n + 1 frames at k, n + k
// and 2n + k: a long session revisiting the same place.
TEST(TrajectoryTest, LapsRepeatTheLoop) {
  std::vector<TrajectoryKind> kinds(std::begin(kLoops), std::end(kLoops));
  kinds.push_back(TrajectoryKind::kTour);
  for (TrajectoryKind kind : kinds) {
    SCOPED_TRACE(std::string(TrajectoryKindName(kind)));
    TrajectoryOptions one = kind == TrajectoryKind::kTour ? TourOptions() : TrajectoryOptions{};
    one.frames = 101;
    TrajectoryOptions three = one;
    three.frames = 301;
    three.laps = 3;
    const std::vector<StampedPose> lap = Make(kind, one);
    const std::vector<StampedPose> laps = Make(kind, three);
    ASSERT_EQ(laps.size(), 301u);
    for (size_t k = 0; k < lap.size(); k += 5) {
      for (size_t l = 0; l < 3; ++l) {
        const Eigen::Isometry3d delta =
            lap[k].T_world_camera.inverse() * laps[100 * l + k].T_world_camera;
        EXPECT_LT(delta.translation().norm(), 1e-6) << "frame " << k << " lap " << l;
        EXPECT_LT(RotationAngle(delta), 1e-6) << "frame " << k << " lap " << l;
      }
    }
  }
  TrajectoryOptions options;
  options.laps = 0;
  EXPECT_EQ(CircleTrajectory(kRoom, options).status().code(), StatusCode::kInvalidArgument);
}

TEST(TrajectoryTest, NamesAndValidation) {
  for (TrajectoryKind kind :
       {TrajectoryKind::kCircle, TrajectoryKind::kFigureEight, TrajectoryKind::kCorridorLoop,
        TrajectoryKind::kPureRotation, TrajectoryKind::kFastMotion, TrajectoryKind::kTour}) {
    StatusOr<TrajectoryKind> parsed = ParseTrajectoryKind(TrajectoryKindName(kind));
    ASSERT_TRUE(parsed.ok());
    EXPECT_EQ(*parsed, kind);
  }
  EXPECT_EQ(ParseTrajectoryKind("spiral").status().code(), StatusCode::kInvalidArgument);
  TrajectoryOptions options;
  options.frames = 0;
  EXPECT_FALSE(CircleTrajectory(kRoom, options).ok());
  options = {};
  options.rate_hz = 0;
  EXPECT_FALSE(FigureEightTrajectory(kRoom, options).ok());
  options = {};
  options.camera_height = 2.7;
  EXPECT_FALSE(CorridorLoopTrajectory(kRoom, options).ok());
  EXPECT_FALSE(
      PureRotationTrajectory(Eigen::AlignedBox3d(Vector3d::Zero(), Vector3d(2, 2, 2)), {}).ok());
  options = {};
  options.frames = 1;
  EXPECT_EQ(FastMotionTrajectory(kRoom, options)->size(), 1u);
}

}  // namespace
}  // namespace semmap::synth
