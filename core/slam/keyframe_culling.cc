#include "core/slam/keyframe_culling.h"

#include <cmath>

namespace semmap {

Status KeyframeCullingOptions::Validate() const {
  if (!std::isfinite(redundant_fraction) || redundant_fraction <= 0 || redundant_fraction > 1) {
    return InvalidArgumentError("keyframe culling redundant_fraction must be in (0, 1]");
  }
  if (min_other_observers < 1) {
    return InvalidArgumentError("keyframe culling min_other_observers must be >= 1");
  }
  return OkStatus();
}

bool IsRedundantKeyframe(int k, const MapPoints& points, const KeyframeCullingOptions& options) {
  const std::vector<int64_t>& seen = points.PointsOf(k);
  if (seen.empty()) return false;
  size_t redundant = 0;
  for (int64_t id : seen) {
    const MapPointState* point = points.Find(id);
    // Its own observation is one of them.
    if (point != nullptr &&
        static_cast<int>(point->observations.size()) - 1 >= options.min_other_observers) {
      ++redundant;
    }
  }
  return static_cast<double>(redundant) >= options.redundant_fraction * seen.size();
}

std::vector<int> CullRedundantKeyframes(int newest, KeyframeGraph& graph, MapPoints& points,
                                        const KeyframeCullingOptions& options) {
  std::vector<int> culled;
  if (!options.enabled) return culled;
  for (const auto& [k, shared] : points.Covisible(newest)) {
    const GraphKeyframe& node = graph.node(k);
    if (k == newest || node.culled || node.index_in_session == 0) continue;
    if (!IsRedundantKeyframe(k, points, options)) continue;
    points.RemoveKeyframe(k);
    graph.Cull(k);
    culled.push_back(k);
  }
  return culled;
}

}  // namespace semmap
