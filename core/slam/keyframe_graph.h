// The back end's keyframe graph of one map: keyframes of every session with their current
// world poses, odometry edges between a session's consecutive keyframes and loop edges, and the
// questions loop closure asks of it (session neighbours, keyframes near a pose). Turns itself
// into a pose graph and takes the optimised poses back. Single-threaded (the back end's worker).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "common/camera.h"
#include "common/status.h"
#include "core/sensor/frame_features.h"
#include "core/slam/pose_graph.h"

namespace semmap {

struct GraphKeyframe {
  int64_t session_id = 0;
  int64_t seq = 0;
  Eigen::Isometry3d T_world_keyframe = Eigen::Isometry3d::Identity();
  std::shared_ptr<const FrameFeatures> features;
  const CameraCalibration* camera = nullptr;  // the session's, owned by the back end
  int index_in_session = 0;                   // 0, 1, 2, ... in the session's order
  // Redundant (keyframe_culling.h): a pose node of the graph only, without features; loop
  // search and session neighbours pass over it.
  bool culled = false;
};

// An edge of the graph is a pose-graph edge whose node ids are the graph's node indices, so the
// edges go to the optimiser as they are.
using GraphEdge = PoseGraphEdge;

class KeyframeGraph {
 public:
  // Appends a keyframe (the next of its session) and returns its node index.
  int Add(GraphKeyframe keyframe);
  void AddEdge(const GraphEdge& edge);
  // Takes back the latest edge (a loop the optimisation showed to be inconsistent).
  void RemoveLastEdge();
  // Marks the keyframe culled and releases its features; it keeps its edges, so the pose
  // graph still chains its neighbours through it.
  void Cull(int index);
  // A kept keyframe's features released (null) or read back (keyframe_feature_memory.h); a
  // culled one keeps none.
  void SetFeatures(int index, std::shared_ptr<const FrameFeatures> features) {
    GraphKeyframe& node = nodes_[static_cast<size_t>(index)];
    if (!node.culled) node.features = std::move(features);
  }
  void SetPose(int index, const Eigen::Isometry3d& T_world_keyframe) {
    nodes_[static_cast<size_t>(index)].T_world_keyframe = T_world_keyframe;
  }

  int size() const { return static_cast<int>(nodes_.size()); }
  const GraphKeyframe& node(int index) const { return nodes_[static_cast<size_t>(index)]; }
  const std::vector<GraphEdge>& edges() const { return edges_; }
  std::optional<int> Find(int64_t session_id, int64_t seq) const;
  // Keyframes joined by edges share a frame; separate components (sessions not yet linked by
  // a loop) do not, so their poses cannot be compared.
  bool SameComponent(int a, int b) const { return Root(a) == Root(b); }
  // The session's `radius` nearest keyframes before and after `index` in its order that are
  // not culled (not itself).
  std::vector<int> SessionNeighbours(int index, int radius) const;
  // The nearest keyframe before `index` in its session's order that is not culled.
  std::optional<int> PreviousKept(int index) const;
  // The latest keyframe of a session, if any.
  std::optional<int> LastOfSession(int64_t session_id) const;
  // Keyframes (not culled) whose camera centre lies within radius_m of T's and whose optical
  // axis is within max_angle_rad of T's, nearest first; `skip` filters candidates out.
  std::vector<int> Near(const Eigen::Isometry3d& T_world_camera, double radius_m,
                        double max_angle_rad, const std::function<bool(int)>& skip) const;

  // Optimises every pose; in each connected component the oldest keyframe stays fixed (a
  // session that never closed a loop with the others keeps its own frame). Returns the
  // solver's result; node poses are replaced on success.
  StatusOr<PoseGraphResult> Optimise(const PoseGraphOptions& options);

 private:
  int Root(int index) const;
  void Union(int a, int b);

  std::vector<GraphKeyframe> nodes_;
  std::vector<GraphEdge> edges_;
  // Union-find over edges; each root is its component's oldest keyframe (the smaller index
  // wins a union). Path halving on lookup, hence mutable.
  mutable std::vector<int> parent_;
  std::map<std::pair<int64_t, int64_t>, int> by_session_seq_;
  std::map<int64_t, std::vector<int>> by_session_;  // node indices in session order
};

}  // namespace semmap
