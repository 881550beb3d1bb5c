#include "core/slam/keyframe_graph.h"

#include <algorithm>
#include <cmath>

namespace semmap {

int KeyframeGraph::Add(GraphKeyframe keyframe) {
  const int index = size();
  std::vector<int>& order = by_session_[keyframe.session_id];
  keyframe.index_in_session = static_cast<int>(order.size());
  order.push_back(index);
  by_session_seq_[{keyframe.session_id, keyframe.seq}] = index;
  nodes_.push_back(std::move(keyframe));
  parent_.push_back(index);
  return index;
}

int KeyframeGraph::Root(int index) const {
  size_t i = static_cast<size_t>(index);
  while (parent_[i] != static_cast<int>(i)) {
    parent_[i] = parent_[static_cast<size_t>(parent_[i])];
    i = static_cast<size_t>(parent_[i]);
  }
  return static_cast<int>(i);
}

void KeyframeGraph::Union(int a, int b) {
  a = Root(a);
  b = Root(b);
  // The smaller index becomes the root: each component's root is its oldest keyframe.
  if (a != b) parent_[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
}

void KeyframeGraph::AddEdge(const GraphEdge& edge) {
  edges_.push_back(edge);
  Union(static_cast<int>(edge.from), static_cast<int>(edge.to));
}

void KeyframeGraph::RemoveLastEdge() {
  if (edges_.empty()) return;
  edges_.pop_back();
  // Union-find cannot split: rebuild it from the remaining edges (rare, linear).
  for (int i = 0; i < size(); ++i) parent_[static_cast<size_t>(i)] = i;
  for (const GraphEdge& e : edges_) Union(static_cast<int>(e.from), static_cast<int>(e.to));
}

std::optional<int> KeyframeGraph::Find(int64_t session_id, int64_t seq) const {
  const auto it = by_session_seq_.find({session_id, seq});
  if (it == by_session_seq_.end()) return std::nullopt;
  return it->second;
}

std::optional<int> KeyframeGraph::LastOfSession(int64_t session_id) const {
  const auto it = by_session_.find(session_id);
  if (it == by_session_.end() || it->second.empty()) return std::nullopt;
  return it->second.back();
}

void KeyframeGraph::Cull(int index) {
  GraphKeyframe& kf = nodes_[static_cast<size_t>(index)];
  kf.culled = true;
  kf.features.reset();
}

std::vector<int> KeyframeGraph::SessionNeighbours(int index, int radius) const {
  const GraphKeyframe& kf = node(index);
  const std::vector<int>& order = by_session_.at(kf.session_id);
  std::vector<int> before, after;
  for (int pos = kf.index_in_session - 1; pos >= 0 && static_cast<int>(before.size()) < radius;
       --pos) {
    if (!node(order[static_cast<size_t>(pos)]).culled)
      before.push_back(order[static_cast<size_t>(pos)]);
  }
  for (int pos = kf.index_in_session + 1;
       pos < static_cast<int>(order.size()) && static_cast<int>(after.size()) < radius; ++pos) {
    if (!node(order[static_cast<size_t>(pos)]).culled)
      after.push_back(order[static_cast<size_t>(pos)]);
  }
  // Nearest first, alternating sides as before culling existed.
  std::vector<int> out;
  for (size_t d = 0; d < std::max(before.size(), after.size()); ++d) {
    if (d < before.size()) out.push_back(before[d]);
    if (d < after.size()) out.push_back(after[d]);
  }
  return out;
}

std::optional<int> KeyframeGraph::PreviousKept(int index) const {
  const GraphKeyframe& kf = node(index);
  const std::vector<int>& order = by_session_.at(kf.session_id);
  for (int pos = kf.index_in_session - 1; pos >= 0; --pos) {
    if (!node(order[static_cast<size_t>(pos)]).culled) return order[static_cast<size_t>(pos)];
  }
  return std::nullopt;
}

std::vector<int> KeyframeGraph::Near(const Eigen::Isometry3d& T_world_camera, double radius_m,
                                     double max_angle_rad,
                                     const std::function<bool(int)>& skip) const {
  const Eigen::Vector3d axis = T_world_camera.linear().col(2);
  const double min_cos = std::cos(max_angle_rad);
  std::vector<std::pair<double, int>> found;
  for (int i = 0; i < size(); ++i) {
    if (nodes_[static_cast<size_t>(i)].culled || (skip && skip(i))) continue;
    const Eigen::Isometry3d& T = nodes_[static_cast<size_t>(i)].T_world_keyframe;
    const double distance = (T.translation() - T_world_camera.translation()).norm();
    if (distance > radius_m || T.linear().col(2).dot(axis) < min_cos) continue;
    found.emplace_back(distance, i);
  }
  std::sort(found.begin(), found.end());
  std::vector<int> out;
  out.reserve(found.size());
  for (const auto& [distance, i] : found) out.push_back(i);
  return out;
}

StatusOr<PoseGraphResult> KeyframeGraph::Optimise(const PoseGraphOptions& options) {
  std::vector<PoseGraphNode> nodes(nodes_.size());
  for (int i = 0; i < size(); ++i) {
    nodes[static_cast<size_t>(i)].id = i;
    nodes[static_cast<size_t>(i)].T_world_node = nodes_[static_cast<size_t>(i)].T_world_keyframe;
  }
  for (int i = 0; i < size(); ++i) {
    if (Root(i) == i) nodes[static_cast<size_t>(i)].fixed = true;
  }
  SEMMAP_ASSIGN_OR_RETURN(PoseGraphResult result, OptimizePoseGraph(nodes, edges_, options));
  for (const auto& [id, T] : result.T_world_node) {
    nodes_[static_cast<size_t>(id)].T_world_keyframe = T;
  }
  return result;
}

}  // namespace semmap
