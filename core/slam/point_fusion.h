// Map-point fusion by projection (ORB-SLAM2's SearchInNeighbors / Fuse): a new keyframe looks
// for the points its neighbours observe in its own keypoints. Where one is found on a keypoint
// that observes nothing, the keypoint becomes an observation of it; where the keypoint already
// observes another point, the two are one 3D point reached twice and are fused. Without it a
// place walked again (a second lap, a revisit before a loop closes) starts new points beside
// the old ones: covisibility never links the visits, bundle adjustment cannot tie them, and
// keyframe culling never finds the old keyframes redundant.
#pragma once

#include <vector>

#include "common/status.h"
#include "core/slam/keyframe_graph.h"
#include "core/slam/map_points.h"

namespace semmap {

struct PointFusionOptions {
  // Off by default: even merging only fresh duplicates (below), ICL kt2's ATE has a heavy tail
  // with fusion on (4 of 13 runs over 20 mm, 1 of 7 off; docs/architecture.md). On, a
  // revisited place shares its points, so keyframe culling finds the revisits' keyframes
  // redundant.
  bool enabled = false;
  // Keypoints within this many pixels (times the scale factor to the point's pyramid level) of
  // a point's projection are candidates.
  double search_radius_px = 3.0;
  double octave_scale = 1.2;  // features.orb_scale_factor
  // ... matching its descriptor within this Hamming distance (ORB-SLAM2's TH_LOW).
  int max_descriptor_distance = 50;
  // A candidate must pass the chi-square test local bundle adjustment applies to its
  // observations (95 %): reprojection error in units of the keypoint's pixel sigma
  // (octave_scale^octave), 2 dof; with measured depth also the inverse-depth error in units of
  // inverse_depth_sigma, 3 dof. A looser gate joins observations BA then throws out again.
  double max_reprojection_chi2 = 5.991;
  double max_chi2_with_depth = 7.815;
  double inverse_depth_sigma = 3e-3;  // 1/m; BundleAdjustmentOptions::inverse_depth_sigma
  // Off: a duplicate is merged only while one of the two is fresh (one observation, i.e. only
  // the keyframe that created it sees it). Measured, merging two established points (each seen
  // by two or more keyframes, each pulled into place by its own bundle adjustments) is where
  // fusion's ATE cost came from (docs/architecture.md); both then stay and BA weighs them.
  bool merge_established = false;

  Status Validate() const;  // INVALID_ARGUMENT naming the field
};

struct PointFusionResult {
  int observations_added = 0;  // keypoints that observed nothing now observe a neighbour's point
  int points_fused = 0;        // duplicates merged (the one with more observations kept)
};

// Projects the points observed by `neighbours` (graph indices; culled ones and `keyframe`
// itself are skipped) into `keyframe` (not culled, with features and a camera) at its current
// pose, and adds or fuses as above. Binary descriptors only (a keyframe with float
// descriptors is left alone).
PointFusionResult FusePointsIntoKeyframe(int keyframe, const std::vector<int>& neighbours,
                                         const KeyframeGraph& graph, MapPoints& points,
                                         const PointFusionOptions& options);

}  // namespace semmap
