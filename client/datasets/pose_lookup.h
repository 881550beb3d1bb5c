// Pose of a camera at an arbitrary stamp, from a trajectory sampled at other stamps (ground
// truth or known poses at mocap rate vs. camera frames).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "client/datasets/trajectory_io.h"

namespace semmap {

struct PoseLookupOptions {
  // Interpolate only between neighbours at most this far apart: across a tracking gap the
  // motion is unknown, and a made-up pose is worse than none.
  int64_t max_interp_gap_ns = 100'000'000;  // 0.1 s
  // Outside the trajectory's span, the nearest end pose is used up to this far away
  // (TUM ground truth often starts a little after the first image: 0.14 s for fr3/teddy).
  int64_t max_extrapolation_ns = 200'000'000;  // 0.2 s
};

class PoseLookup {
 public:
  // `poses` should be sorted by stamp; they are sorted (stably) here when they are not.
  explicit PoseLookup(std::vector<StampedPose> poses, PoseLookupOptions options = {});

  // An exact stamp gives its pose; inside the span, linear/slerp interpolation between the
  // neighbours; outside it, the nearest end pose within max_extrapolation; else nullopt.
  std::optional<Eigen::Isometry3d> At(int64_t stamp_ns) const;

  const std::vector<StampedPose>& poses() const { return poses_; }
  bool empty() const { return poses_.empty(); }
  size_t size() const { return poses_.size(); }

 private:
  std::vector<StampedPose> poses_;
  PoseLookupOptions options_;
};

}  // namespace semmap
