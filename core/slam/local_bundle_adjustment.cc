#include "core/slam/local_bundle_adjustment.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace semmap {

Status LocalBundleAdjustmentOptions::Validate() const {
  if (max_free_keyframes < 1) {
    return InvalidArgumentError("local BA max_free_keyframes must be >= 1");
  }
  if (max_fixed_keyframes < 0) {
    return InvalidArgumentError("local BA max_fixed_keyframes must be >= 0");
  }
  if (min_points < 1) return InvalidArgumentError("local BA min_points must be >= 1");
  if (!std::isfinite(octave_scale) || octave_scale < 1) {
    return InvalidArgumentError("local BA octave_scale must be >= 1");
  }
  if (!std::isfinite(final_ba_max_solve_seconds) || final_ba_max_solve_seconds < 0) {
    return InvalidArgumentError("final BA max solve seconds must be >= 0");
  }
  SEMMAP_RETURN_IF_ERROR(points.Validate().WithContext("local BA"));
  return solver.Validate().WithContext("local BA");
}

namespace {

// Bundle-adjusts `window` (fixed keyframes held, the first free one too when none is fixed) and
// applies the result to `graph` and `points`.
StatusOr<LocalBundleAdjustmentReport> AdjustWindow(const BundleAdjustmentWindow& window,
                                                   KeyframeGraph& graph, MapPoints& points,
                                                   const LocalBundleAdjustmentOptions& options,
                                                   const BundleAdjustmentOptions& solver) {
  LocalBundleAdjustmentReport report;
  if (static_cast<int>(window.points.size()) < options.min_points) return report;

  std::vector<BundleAdjustmentKeyframe> keyframes;
  const auto add_keyframe = [&](int k, bool fixed) {
    const GraphKeyframe& node = graph.node(k);
    keyframes.push_back({k, node.T_world_keyframe, *node.camera, fixed});
  };
  // Without fixed keyframes the oldest free one holds the gauge (BundleAdjust fixes the first).
  for (int k : window.fixed_keyframes) add_keyframe(k, true);
  for (int k : window.free_keyframes) add_keyframe(k, false);
  std::vector<bool> in_window(static_cast<size_t>(graph.size()), false);
  for (const BundleAdjustmentKeyframe& k : keyframes) in_window[static_cast<size_t>(k.id)] = true;
  std::vector<BundleAdjustmentPoint> ba_points;
  std::vector<BundleAdjustmentObservation> observations;
  ba_points.reserve(window.points.size());
  for (int64_t id : window.points) {
    const MapPointState* p = points.Find(id);
    ba_points.push_back({id, p->position_world, false});
    for (const MapPointObservation& o : p->observations) {
      if (!in_window[static_cast<size_t>(o.keyframe)]) continue;
      BundleAdjustmentObservation obs;
      obs.keyframe_id = o.keyframe;
      obs.point_id = id;
      obs.pixel = Eigen::Vector2d(o.u, o.v);
      obs.pixel_sigma = std::pow(options.octave_scale, o.octave);
      if (o.inverse_depth > 0) obs.inverse_depth = o.inverse_depth;
      observations.push_back(obs);
    }
  }
  // The loops the pose graph closed between keyframes of the window: their two sides share no
  // points unless fused, and without the edge BA would let the loop open again.
  std::vector<PoseGraphEdge> loops;
  if (options.loop_constraints) {
    for (const GraphEdge& e : graph.edges()) {
      if (e.kind == PoseGraphEdgeKind::kLoop && in_window[static_cast<size_t>(e.from)] &&
          in_window[static_cast<size_t>(e.to)]) {
        loops.push_back(e);
      }
    }
  }
  StatusOr<BundleAdjustmentResult> result =
      BundleAdjust(keyframes, ba_points, observations, solver, loops);
  if (!result.ok()) return result.status();

  report.ran = true;
  report.free_keyframes = static_cast<int>(window.free_keyframes.size());
  report.fixed_keyframes = static_cast<int>(window.fixed_keyframes.size());
  report.points = static_cast<int>(ba_points.size());
  report.observations = static_cast<int>(observations.size());
  report.loop_constraints = static_cast<int>(loops.size());
  report.solve_ms = result->solve_ms;
  report.hit_time_limit = result->hit_time_limit;
  for (size_t i = 0; i < keyframes.size(); ++i) {
    if (keyframes[i].fixed) continue;
    const int k = static_cast<int>(keyframes[i].id);
    report.moved_keyframes.emplace_back(k, graph.node(k).T_world_keyframe);
    graph.SetPose(k, result->T_world_keyframe[i].second);
  }
  for (const auto& [id, position] : result->position_world) points.SetPosition(id, position);
  for (size_t i = 0; i < observations.size(); ++i) {
    if (!result->outlier[i]) continue;
    points.RemoveObservation(observations[i].point_id,
                             static_cast<int>(observations[i].keyframe_id));
    ++report.outliers_removed;
  }
  return report;
}

}  // namespace

StatusOr<LocalBundleAdjustmentReport> RunLocalBundleAdjustment(
    int keyframe, KeyframeGraph& graph, MapPoints& points,
    const LocalBundleAdjustmentOptions& options) {
  const BundleAdjustmentWindow window =
      points.LocalWindow(keyframe, options.max_free_keyframes, options.max_fixed_keyframes);
  SEMMAP_ASSIGN_OR_RETURN(LocalBundleAdjustmentReport report,
                          AdjustWindow(window, graph, points, options, options.solver));
  if (report.ran) {
    const GraphKeyframe& newest = graph.node(keyframe);
    report.points_culled = points.Cull(newest.session_id, newest.index_in_session);
  }
  return report;
}

StatusOr<LocalBundleAdjustmentReport> RunSessionBundleAdjustment(
    const std::set<int64_t>& session_ids, KeyframeGraph& graph, MapPoints& points,
    const LocalBundleAdjustmentOptions& options, double max_solve_seconds) {
  BundleAdjustmentWindow window;
  std::vector<bool> is_free(static_cast<size_t>(graph.size()), false);
  for (int k = 0; k < graph.size(); ++k) {
    if (session_ids.count(graph.node(k).session_id) == 0 || points.PointsOf(k).empty()) continue;
    window.free_keyframes.push_back(k);
    is_free[static_cast<size_t>(k)] = true;
    for (int64_t id : points.PointsOf(k)) window.points.push_back(id);
  }
  std::sort(window.points.begin(), window.points.end());
  window.points.erase(std::unique(window.points.begin(), window.points.end()), window.points.end());
  std::set<int> fixed;
  for (int64_t id : window.points) {
    for (const MapPointObservation& o : points.Find(id)->observations) {
      if (!is_free[static_cast<size_t>(o.keyframe)]) fixed.insert(o.keyframe);
    }
  }
  // One keyframe per component already held; a component of the sessions' keyframes that no
  // other keyframe holds keeps its frame through its oldest keyframe (graph order is age).
  std::vector<int> holding;
  const auto held = [&](int k) {
    return std::any_of(holding.begin(), holding.end(),
                       [&](int h) { return graph.SameComponent(h, k); });
  };
  for (int f : fixed) {
    if (!held(f)) holding.push_back(f);
  }
  std::vector<int> free;
  for (int k : window.free_keyframes) {
    if (held(k)) {
      free.push_back(k);
    } else {
      holding.push_back(k);
      fixed.insert(k);
    }
  }
  window.free_keyframes = std::move(free);
  window.fixed_keyframes.assign(fixed.begin(), fixed.end());
  BundleAdjustmentOptions solver = options.solver;
  solver.max_solve_seconds = max_solve_seconds;
  return AdjustWindow(window, graph, points, options, solver);
}

}  // namespace semmap
