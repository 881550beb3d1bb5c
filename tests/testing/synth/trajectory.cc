#include "tests/testing/synth/trajectory.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "tests/testing/synth/rng.h"

namespace semmap::synth {
namespace {

using Eigen::Vector3d;

constexpr double kTwoPi = 2.0 * std::numbers::pi;
constexpr uint64_t kFastStream = 0x666173744D6F7665ULL;  // "fastMove"

struct Geometry {
  Vector3d centre;  // room centre at camera height
  double hx, hy;    // half extents of the room's floor
};

Geometry RoomGeometry(const Eigen::AlignedBox3d& room, const TrajectoryOptions& options) {
  Geometry g;
  g.centre = room.center();
  g.centre.z() = room.min().z() + options.camera_height;
  g.hx = 0.5 * room.sizes().x();
  g.hy = 0.5 * room.sizes().y();
  return g;
}

// Whole microseconds after the start, so stamps survive TUM files (microsecond text) exactly.
int64_t StampOf(const TrajectoryOptions& options, int i) {
  return options.start_stamp_ns +
         1000 * static_cast<int64_t>(std::llround(i * 1e6 / options.rate_hz));
}

// Laps completed at frame i: 0 at the first frame, options.laps at the last.
double LapFraction(const TrajectoryOptions& options, int i) {
  return options.frames > 1 ? static_cast<double>(options.laps) * i / (options.frames - 1) : 0.0;
}

template <typename PoseAt>
StatusOr<std::vector<StampedPose>> Generate(const Eigen::AlignedBox3d& room,
                                            const TrajectoryOptions& options, PoseAt pose_at) {
  SEMMAP_RETURN_IF_ERROR(ValidateTrajectoryOptions(room, options));
  const Geometry g = RoomGeometry(room, options);
  std::vector<StampedPose> poses;
  poses.reserve(static_cast<size_t>(options.frames));
  for (int i = 0; i < options.frames; ++i) {
    poses.push_back(StampedPose{StampOf(options, i), pose_at(g, i)});
  }
  return poses;
}

// Position and heading along an anticlockwise rounded rectangle of half extents (a, b) and
// corner radius r, at arc length s from the middle of its +x side.
void RoundedRectangle(double a, double b, double r, double s, Vector3d* position, double* heading) {
  const double ly = 2.0 * (b - r), lx = 2.0 * (a - r), arc = 0.5 * std::numbers::pi * r;
  const double perimeter = 2.0 * (lx + ly) + 4.0 * arc;
  s = std::fmod(s + 0.5 * ly, perimeter);  // start half-way up the +x side
  if (s < 0) s += perimeter;
  // Four sides, each followed by a corner; side k heads at 90 + 90k degrees.
  const double side_lengths[4] = {ly, lx, ly, lx};
  const Vector3d side_starts[4] = {
      {a, -(b - r), 0}, {a - r, b, 0}, {-a, b - r, 0}, {-(a - r), -b, 0}};
  const Vector3d corner_centres[4] = {
      {a - r, b - r, 0}, {-(a - r), b - r, 0}, {-(a - r), -(b - r), 0}, {a - r, -(b - r), 0}};
  for (int k = 0; k < 4; ++k) {
    const double dir = 0.5 * std::numbers::pi * (k + 1);
    if (s <= side_lengths[k]) {
      *position = side_starts[k] + s * Vector3d(std::cos(dir), std::sin(dir), 0);
      *heading = dir;
      return;
    }
    s -= side_lengths[k];
    if (s <= arc || k == 3) {
      const double angle =
          0.5 * std::numbers::pi * k + std::min(s, arc) / r;  // from the corner's centre
      *position = corner_centres[k] + r * Vector3d(std::cos(angle), std::sin(angle), 0);
      *heading = angle + 0.5 * std::numbers::pi;
      return;
    }
    s -= arc;
  }
}

}  // namespace

Status ValidateTrajectoryOptions(const Eigen::AlignedBox3d& room,
                                 const TrajectoryOptions& options) {
  if (options.frames < 1 || options.frames > 1'000'000) {
    return InvalidArgumentError("trajectory frames must be 1..1000000, got " +
                                std::to_string(options.frames));
  }
  if (!std::isfinite(options.rate_hz) || options.rate_hz <= 0 || options.rate_hz > 1000) {
    return InvalidArgumentError("trajectory rate must be in (0, 1000] Hz, got " +
                                std::to_string(options.rate_hz));
  }
  if (options.laps < 1 || options.laps > 1000) {
    return InvalidArgumentError("trajectory laps must be 1..1000, got " +
                                std::to_string(options.laps));
  }
  if (room.isEmpty() || !room.sizes().allFinite() || room.sizes().x() < 3.0 ||
      room.sizes().y() < 3.0 || room.sizes().z() < 2.0) {
    return InvalidArgumentError("trajectories need a room of at least 3 x 3 x 2 m");
  }
  if (!std::isfinite(options.camera_height) || options.camera_height < 0.3 ||
      options.camera_height > room.sizes().z() - 0.3) {
    return InvalidArgumentError("camera height must stay 0.3 m clear of floor and ceiling, got " +
                                std::to_string(options.camera_height));
  }
  return OkStatus();
}

Eigen::Isometry3d LookingPose(const Vector3d& position, double yaw, double pitch, double roll) {
  const Vector3d forward(std::cos(pitch) * std::cos(yaw), std::cos(pitch) * std::sin(yaw),
                         std::sin(pitch));
  const Vector3d right = Vector3d(std::sin(yaw), -std::cos(yaw), 0.0);  // forward x up, unit
  const Vector3d down = forward.cross(right);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear().col(0) = std::cos(roll) * right + std::sin(roll) * down;
  T.linear().col(1) = -std::sin(roll) * right + std::cos(roll) * down;
  T.linear().col(2) = forward;
  T.translation() = position;
  return T;
}

StatusOr<std::vector<StampedPose>> CircleTrajectory(const Eigen::AlignedBox3d& room,
                                                    const TrajectoryOptions& options) {
  return Generate(room, options, [&](const Geometry& g, int i) {
    const double phi = kTwoPi * LapFraction(options, i);
    const double radius = 0.36 * std::min(g.hx, g.hy);
    const Vector3d p = g.centre + Vector3d(radius * std::cos(phi), radius * std::sin(phi),
                                           0.05 * std::sin(2.0 * phi));
    return LookingPose(p, phi + 0.25 * std::sin(2.0 * phi), -0.2 + 0.05 * std::sin(3.0 * phi),
                       0.03 * std::sin(2.0 * phi));
  });
}

StatusOr<std::vector<StampedPose>> FigureEightTrajectory(const Eigen::AlignedBox3d& room,
                                                         const TrajectoryOptions& options) {
  return Generate(room, options, [&](const Geometry& g, int i) {
    const double phi = kTwoPi * LapFraction(options, i);
    const double a = 0.5 * g.hx, b = 0.3 * g.hy;
    const Vector3d p =
        g.centre + Vector3d(a * std::sin(phi), b * std::sin(2.0 * phi), 0.04 * std::sin(3.0 * phi));
    // Looks roughly along the path: the sideways part of the direction is damped (0.55), which
    // spreads the turning evenly between the tight ends of the lobes and their outer bends.
    const double heading = std::atan2(0.55 * 2.0 * b * std::cos(2.0 * phi), a * std::cos(phi));
    return LookingPose(p, heading, -0.18 + 0.05 * std::sin(phi), 0.02 * std::sin(2.0 * phi));
  });
}

StatusOr<std::vector<StampedPose>> CorridorLoopTrajectory(const Eigen::AlignedBox3d& room,
                                                          const TrajectoryOptions& options) {
  return Generate(room, options, [&](const Geometry& g, int i) {
    const double a = 0.5 * g.hx, b = 0.44 * g.hy, r = 0.75 * std::min(a, b);
    const double perimeter = 4.0 * (a - r) + 4.0 * (b - r) + kTwoPi * r;
    const double u = LapFraction(options, i);
    Vector3d offset;
    double heading = 0;
    RoundedRectangle(a, b, r, u * perimeter, &offset, &heading);
    offset.z() = 0.03 * std::sin(kTwoPi * 4.0 * u);
    return LookingPose(g.centre + offset, heading - std::numbers::pi / 3.0,
                       -0.15 + 0.04 * std::sin(kTwoPi * 3.0 * u));
  });
}

StatusOr<std::vector<StampedPose>> PureRotationTrajectory(const Eigen::AlignedBox3d& room,
                                                          const TrajectoryOptions& options) {
  return Generate(room, options, [&](const Geometry& g, int i) {
    const double phi = kTwoPi * LapFraction(options, i);
    return LookingPose(g.centre, phi, -0.15 + 0.12 * std::sin(2.0 * phi), 0.05 * std::sin(phi));
  });
}

StatusOr<std::vector<StampedPose>> FastMotionTrajectory(const Eigen::AlignedBox3d& room,
                                                        const TrajectoryOptions& options) {
  Rng rng(DeriveSeed(options.seed, kFastStream));
  // Two sinusoids per axis (a slow sweep and a quick shake), a steady turn plus a wobble.
  double freq[8], phase[8];
  for (int k = 0; k < 8; ++k) {
    freq[k] = kTwoPi * (k % 2 == 0 ? rng.Uniform(0.5, 0.8) : rng.Uniform(1.2, 1.8));
    phase[k] = rng.Uniform(0.0, kTwoPi);
  }
  const double turn_sign = rng.Bernoulli(0.5) ? 1.0 : -1.0;
  const double turn_rate = turn_sign * rng.Uniform(1.2, 2.0);  // rad/s
  const double yaw0 = rng.Uniform(0.0, kTwoPi);
  return Generate(room, options, [&](const Geometry& g, int i) {
    const double t = i / options.rate_hz;
    const double scale = std::min(g.hx, g.hy) / 2.5;
    auto wave = [&](int k, double amplitude) {
      return amplitude * std::sin(freq[k] * t + phase[k]);
    };
    const Vector3d p =
        g.centre + Vector3d(scale * (wave(0, 0.35) + wave(1, 0.15)),
                            scale * (wave(2, 0.35) + wave(3, 0.15)), wave(4, 0.12) + wave(5, 0.03));
    const double yaw = yaw0 + turn_rate * t + wave(6, 0.5);
    const double pitch = -0.15 + 0.2 * std::sin(freq[7] * t + phase[0]);
    const double roll = 0.12 * std::sin(freq[1] * 1.1 * t + phase[7]);
    return LookingPose(p, yaw, pitch, roll);
  });
}

StatusOr<std::vector<StampedPose>> TourTrajectory(const Eigen::AlignedBox3d& room,
                                                  const TrajectoryOptions& options) {
  if (options.tour_targets.empty()) return InvalidArgumentError("a tour needs targets");
  if (!(options.tour_distance >= 0.3 && options.tour_distance <= 5.0)) {
    return InvalidArgumentError("tour distance must be in [0.3, 5] m");
  }
  const Geometry geometry = RoomGeometry(room, options);
  // Each stop: where the camera stands (the target's horizontal normal, clamped inside the
  // room) and the sideways direction of its step.
  struct Stop {
    Vector3d target, stand, side;
  };
  std::vector<Stop> stops;
  for (const TrajectoryOptions::ViewTarget& t : options.tour_targets) {
    Vector3d n(t.normal.x(), t.normal.y(), 0.0);
    if (n.norm() < 1e-6 || !t.point.allFinite()) {
      return InvalidArgumentError("tour targets need a finite point and a non-vertical normal");
    }
    n.normalize();
    Vector3d stand = t.point + options.tour_distance * n;
    stand.z() = geometry.centre.z();
    const Vector3d lo = room.min() + Vector3d::Constant(0.4),
                   hi = room.max() - Vector3d::Constant(0.4);
    stand = stand.cwiseMax(lo).cwiseMin(hi);
    stand.z() = geometry.centre.z();
    stops.push_back({t.point, stand, Vector3d(-n.y(), n.x(), 0.0)});
  }
  const auto look = [](const Vector3d& from, const Vector3d& at, double* yaw, double* pitch) {
    const Vector3d d = at - from;
    *yaw = std::atan2(d.y(), d.x());
    *pitch = std::atan2(d.z(), std::hypot(d.x(), d.y()));
  };
  const auto smooth = [](double u) { return u * u * (3.0 - 2.0 * u); };
  const int n = static_cast<int>(stops.size());
  return Generate(room, options, [&](const Geometry&, int i) {
    // Each stop's share of the lap: 40 % stepping sideways at it, 60 % walking to the next.
    const double laps = LapFraction(options, i);
    const double u = (laps - std::floor(laps)) * n;  // within this lap
    const int k = std::min(static_cast<int>(u), n - 1);
    const double f = u - k;
    const Stop& a = stops[static_cast<size_t>(k)];
    const Stop& b = stops[static_cast<size_t>((k + 1) % n)];
    double yaw = 0, pitch = 0;
    if (f < 0.4) {
      const double s = std::sin(kTwoPi * f / 0.4);  // out to one side, across, back
      const Vector3d p = a.stand + 0.15 * s * a.side;
      look(p, a.target, &yaw, &pitch);
      return LookingPose(p, yaw, pitch);
    }
    const double w = smooth((f - 0.4) / 0.6);
    const Vector3d p = (1.0 - w) * a.stand + w * b.stand;
    double yaw_a = 0, pitch_a = 0, yaw_b = 0, pitch_b = 0;
    look(a.stand, a.target, &yaw_a, &pitch_a);
    look(b.stand, b.target, &yaw_b, &pitch_b);
    const double turn = std::remainder(yaw_b - yaw_a, kTwoPi);  // the short way round
    return LookingPose(p, yaw_a + w * turn, (1.0 - w) * pitch_a + w * pitch_b);
  });
}

StatusOr<TrajectoryKind> ParseTrajectoryKind(std::string_view name) {
  for (TrajectoryKind kind :
       {TrajectoryKind::kCircle, TrajectoryKind::kFigureEight, TrajectoryKind::kCorridorLoop,
        TrajectoryKind::kPureRotation, TrajectoryKind::kFastMotion, TrajectoryKind::kTour}) {
    if (name == TrajectoryKindName(kind)) return kind;
  }
  return InvalidArgumentError("unknown trajectory '" + std::string(name) +
                              "' (expected circle, figure8, corridor, rotation, fast or tour)");
}

std::string_view TrajectoryKindName(TrajectoryKind kind) {
  switch (kind) {
    case TrajectoryKind::kCircle:
      return "circle";
    case TrajectoryKind::kFigureEight:
      return "figure8";
    case TrajectoryKind::kCorridorLoop:
      return "corridor";
    case TrajectoryKind::kPureRotation:
      return "rotation";
    case TrajectoryKind::kFastMotion:
      return "fast";
    case TrajectoryKind::kTour:
      return "tour";
  }
  return "unknown";
}

StatusOr<std::vector<StampedPose>> MakeTrajectory(TrajectoryKind kind,
                                                  const Eigen::AlignedBox3d& room,
                                                  const TrajectoryOptions& options) {
  switch (kind) {
    case TrajectoryKind::kCircle:
      return CircleTrajectory(room, options);
    case TrajectoryKind::kFigureEight:
      return FigureEightTrajectory(room, options);
    case TrajectoryKind::kCorridorLoop:
      return CorridorLoopTrajectory(room, options);
    case TrajectoryKind::kPureRotation:
      return PureRotationTrajectory(room, options);
    case TrajectoryKind::kFastMotion:
      return FastMotionTrajectory(room, options);
    case TrajectoryKind::kTour:
      return TourTrajectory(room, options);
  }
  return InvalidArgumentError("unknown trajectory kind");
}

}  // namespace semmap::synth
