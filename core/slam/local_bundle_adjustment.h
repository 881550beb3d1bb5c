// Local bundle adjustment after each keyframe (the back end's thread, off the tracking path):
// the new keyframe and its most covisible keyframes are free, the points they observe are free,
// and the other keyframes that see those points hold the solution in place (fixed). The
// refined poses go back into the keyframe graph and the points into the map points;
// observations the solver rejects are removed and points too few keyframes confirm are culled.
// The caller moves frames, layers and trackers after the keyframes, as after a pose-graph
// optimisation.
#pragma once

#include <Eigen/Geometry>
#include <set>
#include <utility>
#include <vector>

#include "common/status.h"
#include "core/slam/bundle_adjustment.h"
#include "core/slam/keyframe_graph.h"
#include "core/slam/map_points.h"

namespace semmap {

struct LocalBundleAdjustmentOptions {
  bool enabled = true;
  int max_free_keyframes = 8;    // the new keyframe and its most covisible ones
  int max_fixed_keyframes = 16;  // other keyframes observing the window's points
  // A window with fewer points than this is not worth a solve.
  int min_points = 20;
  double octave_scale = 1.2;  // keypoint sigma = octave_scale^octave pixels
  // Fuse the map points an accepted loop's inlier matches pair up (the same point reached from
  // both sides), so BA sees the loop through shared points. Off by default: on the sequences
  // held (teddy, 7-Scenes redkitchen, ICL kt2) it changed ATE by less than run-to-run noise
  // while making the windows after a loop larger and slower.
  bool fuse_loop_points = false;
  // Loop edges between keyframes of a window enter its BA as relative-pose constraints (with the
  // pose graph's information), so BA keeps what loop closure corrected.
  bool loop_constraints = true;
  // A BA over the ending session's keyframes and points when it ends (its Drain; the whole map
  // when it has one session: RunSessionBundleAdjustment), each of its two solves bounded by
  // final_ba_max_solve_seconds (0: unbounded). On by default: ATE on ICL kt2
  // 23 -> 12-13 mm, teddy 4.1 -> 3.2-3.8 mm, 7-Scenes redkitchen 45.6-47.0 -> 45.8-48.7 mm
  // (its ground truth's floor); under 0.7 s for ~90 keyframes.
  bool final_ba = true;
  double final_ba_max_solve_seconds = 10;
  MapPointsOptions points;
  BundleAdjustmentOptions solver = [] {
    BundleAdjustmentOptions o;
    o.max_solve_seconds = 0.05;  // per solve (two per run): the back end must keep up
    return o;
  }();

  Status Validate() const;
};

struct LocalBundleAdjustmentReport {
  bool ran = false;
  int free_keyframes = 0, fixed_keyframes = 0, points = 0, observations = 0;
  int loop_constraints = 0;  // loop edges inside the window, kept as pose constraints
  int outliers_removed = 0;
  int points_culled = 0;
  double solve_ms = 0;
  bool hit_time_limit = false;
  // Free keyframes whose pose was replaced: (graph index, pose before), what the caller needs
  // to move the frames, layers and trackers that follow them.
  std::vector<std::pair<int, Eigen::Isometry3d>> moved_keyframes;
};

// Runs the local BA of keyframe `keyframe` and applies it to `graph` and `points`.
// FAILED_PRECONDITION when the solver fails (graph and points unchanged).
StatusOr<LocalBundleAdjustmentReport> RunLocalBundleAdjustment(
    int keyframe, KeyframeGraph& graph, MapPoints& points,
    const LocalBundleAdjustmentOptions& options);

// Bundle adjustment at a session's end (--final-ba): every keyframe of `session_ids` that has
// map points is free, with every point they observe; the other keyframes observing those
// points are fixed; a component of the sessions' keyframes that no fixed keyframe holds keeps
// its frame through its oldest keyframe. For a map with one session this is a global BA. For a
// map revisited every day its cost follows the visit, not the map, and the keyframes earlier
// visits left stay where their own final BA put them (so do the layers built from them). Each
// solve bounded by max_solve_seconds (0: unbounded). No culling.
StatusOr<LocalBundleAdjustmentReport> RunSessionBundleAdjustment(
    const std::set<int64_t>& session_ids, KeyframeGraph& graph, MapPoints& points,
    const LocalBundleAdjustmentOptions& options, double max_solve_seconds);

}  // namespace semmap
