// Camera trajectories through a room: stamped T_world_camera poses (OpenCV camera axes: x
// right, y down, z forward; world z up) that stay well inside the room and look at its
// textured walls, furniture and objects (slightly downwards, never at a surface closer than
// about half a metre in the default room).
//
// The loops (circle, figure-eight, corridor, tour) and the pure rotation make exactly
// `laps` laps (default one) over the requested frames, so the last pose equals the first (a
// revisit for loop closure) and the speed follows from the frame count (300 frames a lap at
// 30 Hz: about 0.5 m/s). Fast motion is
// time-based (about 1.5-3 m/s and up to ~200 deg/s at any frame count) and varies with the
// seed; it does not return to its start.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string_view>
#include <vector>

#include "client/datasets/trajectory_io.h"
#include "common/status.h"

namespace semmap::synth {

struct TrajectoryOptions {
  int frames = 300;
  double rate_hz = 30.0;
  // Laps of a loop over the frames (later laps revisit the first: long sessions over one
  // place). Fast motion ignores it.
  int laps = 1;
  // Frame i is stamped start + i / rate rounded to whole microseconds (exact in TUM files).
  int64_t start_stamp_ns = 1'700'000'000'000'000'000;  // 2023-11-14, a plausible Unix stamp
  double camera_height = 1.3;                          // metres above the floor
  uint64_t seed = 0;                                   // varies the fast-motion path only
  // The tour's stops: points to look at and the direction they face (e.g. each named object's
  // front face), visited in order.
  struct ViewTarget {
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
  };
  std::vector<ViewTarget> tour_targets;
  double tour_distance = 1.0;  // metres from each target (horizontally)
};

// frames 1..1,000,000, rate 0 < r <= 1000 Hz, laps 1..1000, a room at least 3 x 3 x 2 m, the camera
// height within 0.3 m of the floor and ceiling.
Status ValidateTrajectoryOptions(const Eigen::AlignedBox3d& room, const TrajectoryOptions& options);

// A circle of radius 0.36 * min(half room extents) around the room's centre, looking outwards.
StatusOr<std::vector<StampedPose>> CircleTrajectory(const Eigen::AlignedBox3d& room,
                                                    const TrajectoryOptions& options);
// A figure-eight (lemniscate of Gerono, 0.5 x 0.3 of the half extents) looking roughly along
// the path.
StatusOr<std::vector<StampedPose>> FigureEightTrajectory(const Eigen::AlignedBox3d& room,
                                                         const TrajectoryOptions& options);
// A rounded-rectangle loop (a corridor around the room's middle), anticlockwise, looking
// 60 degrees to the right of the way ahead (forwards and at the walls).
StatusOr<std::vector<StampedPose>> CorridorLoopTrajectory(const Eigen::AlignedBox3d& room,
                                                          const TrajectoryOptions& options);
// A full turn about the vertical at the room's centre with the pitch swaying: no translation.
StatusOr<std::vector<StampedPose>> PureRotationTrajectory(const Eigen::AlignedBox3d& room,
                                                          const TrajectoryOptions& options);
// Quick, shaky handheld motion (sums of sinusoids, seeded) around the room's centre.
StatusOr<std::vector<StampedPose>> FastMotionTrajectory(const Eigen::AlignedBox3d& room,
                                                        const TrajectoryOptions& options);

// A tour of options.tour_targets (at least one): at each, the camera stands tour_distance in
// front of it (clamped 0.4 m inside the walls, at camera height) and steps 0.3 m sideways
// while looking at it (parallax, and keyframes that all see the target); between stops it
// walks straight, turning smoothly, and the last stop leads back to the first (a revisit).
StatusOr<std::vector<StampedPose>> TourTrajectory(const Eigen::AlignedBox3d& room,
                                                  const TrajectoryOptions& options);

enum class TrajectoryKind {
  kCircle,
  kFigureEight,
  kCorridorLoop,
  kPureRotation,
  kFastMotion,
  kTour
};

// "circle", "figure8", "corridor", "rotation", "fast", "tour".
StatusOr<TrajectoryKind> ParseTrajectoryKind(std::string_view name);
std::string_view TrajectoryKindName(TrajectoryKind kind);
StatusOr<std::vector<StampedPose>> MakeTrajectory(TrajectoryKind kind,
                                                  const Eigen::AlignedBox3d& room,
                                                  const TrajectoryOptions& options);

// The camera at `position` looking along heading `yaw` (radians about world z from +x) raised
// by `pitch` (radians, positive up), rolled by `roll` about the optical axis.
Eigen::Isometry3d LookingPose(const Eigen::Vector3d& position, double yaw, double pitch,
                              double roll = 0.0);

}  // namespace semmap::synth
