// Keyframe culling (ORB-SLAM2's KeyFrameCulling): a keyframe whose map points are nearly all
// seen by enough other keyframes adds nothing the map needs, so long sessions over the same
// place stop growing. It leaves bundle adjustment, covisibility, loop search and the place
// database and gives up its features; it stays a pose node of the keyframe graph, so odometry
// still chains its neighbours (and stored frames anchored to it are re-anchored by the caller).
#pragma once

#include <vector>

#include "common/status.h"
#include "core/slam/keyframe_graph.h"
#include "core/slam/map_points.h"

namespace semmap {

struct KeyframeCullingOptions {
  bool enabled = true;
  // Culled when at least this fraction of its points is each observed by at least
  // min_other_observers other keyframes (ORB-SLAM2: 90 %, 3).
  double redundant_fraction = 0.9;
  int min_other_observers = 3;

  Status Validate() const;  // INVALID_ARGUMENT naming the field
};

// Whether keyframe `k` is redundant by the options' rule (false without map points).
bool IsRedundantKeyframe(int k, const MapPoints& points, const KeyframeCullingOptions& options);

// Checks the keyframes covisible with `newest` (the keyframe just added and adjusted), one at
// a time, and culls the redundant ones: graph.Cull, and their observations leave the map
// points. Never culls `newest`, a session's first keyframe or one already culled. A keyframe
// with a loop edge may go (unlike ORB-SLAM2's): it stays a pose node, so the pose graph still
// closes the loop through it, and on a revisited place nearly every keyframe has one, which
// kept the revisits' keyframes from ever being culled. Returns the culled graph indices.
std::vector<int> CullRedundantKeyframes(int newest, KeyframeGraph& graph, MapPoints& points,
                                        const KeyframeCullingOptions& options);

}  // namespace semmap
