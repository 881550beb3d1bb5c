#include "client/datasets/pose_lookup.h"

#include <algorithm>
#include <cstdint>
#include <iterator>

#include "common/pose.h"
#include "common/time_util.h"

namespace semmap {
namespace {

bool EarlierStamp(const StampedPose& a, const StampedPose& b) { return a.stamp_ns < b.stamp_ns; }

// Whether a distance exceeds a limit (a negative limit allows nothing but 0).
bool Beyond(uint64_t distance, int64_t limit) {
  return limit < 0 ? distance > 0 : distance > static_cast<uint64_t>(limit);
}

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
    if (Beyond(StampDistanceNs(stamp_ns, after->stamp_ns), options_.max_extrapolation_ns)) {
      return std::nullopt;
    }
    return after->T_world_camera;
  }
  const auto before = std::prev(after);
  if (after == poses_.end()) {
    if (Beyond(StampDistanceNs(before->stamp_ns, stamp_ns), options_.max_extrapolation_ns)) {
      return std::nullopt;
    }
    return before->T_world_camera;
  }
  const uint64_t gap = StampDistanceNs(before->stamp_ns, after->stamp_ns);
  if (Beyond(gap, options_.max_interp_gap_ns)) return std::nullopt;
  const double alpha =
      static_cast<double>(StampDistanceNs(before->stamp_ns, stamp_ns)) / static_cast<double>(gap);
  return InterpolatePose(before->T_world_camera, after->T_world_camera, alpha);
}

}  // namespace semmap
