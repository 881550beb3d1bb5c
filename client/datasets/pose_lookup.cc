#include "client/datasets/pose_lookup.h"

#include <algorithm>

#include "common/pose.h"

namespace semmap {
namespace {

bool EarlierStamp(const StampedPose& a, const StampedPose& b) { return a.stamp_ns < b.stamp_ns; }

}  // namespace

PoseLookup::PoseLookup(std::vector<StampedPose> poses, PoseLookupOptions options)
    : poses_(std::move(poses)), options_(options) {
  if (!std::is_sorted(poses_.begin(), poses_.end(), EarlierStamp)) {
    std::stable_sort(poses_.begin(), poses_.end(), EarlierStamp);
  }
}

std::optional<Eigen::Isometry3d> PoseLookup::At(int64_t stamp_ns) const {
  if (poses_.empty()) return std::nullopt;
  // First pose at or after the stamp.
  const auto after =
      std::lower_bound(poses_.begin(), poses_.end(), stamp_ns,
                       [](const StampedPose& p, int64_t stamp) { return p.stamp_ns < stamp; });
  if (after != poses_.end() && after->stamp_ns == stamp_ns) return after->T_world_camera;
  if (after == poses_.begin()) {
    if (after->stamp_ns - stamp_ns > options_.max_extrapolation_ns) return std::nullopt;
    return after->T_world_camera;
  }
  const auto before = std::prev(after);
  if (after == poses_.end()) {
    if (stamp_ns - before->stamp_ns > options_.max_extrapolation_ns) return std::nullopt;
    return before->T_world_camera;
  }
  const int64_t gap = after->stamp_ns - before->stamp_ns;
  if (gap > options_.max_interp_gap_ns) return std::nullopt;
  const double alpha = static_cast<double>(stamp_ns - before->stamp_ns) / static_cast<double>(gap);
  return InterpolatePose(before->T_world_camera, after->T_world_camera, alpha);
}

}  // namespace semmap
